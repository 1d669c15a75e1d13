"""Bad input (docs/specification.md 8) and the Co-Simulation status functions (section 7).

Every bad call must return fmi2Error, log an error message that names the variable and
the value, and leave the instance as it was: getReal shows the previous values, and the
instance steps on bit-identically to a twin that never saw the bad call. After any error
the instance can be restored with fmi2SetFMUstate or reset with fmi2Reset.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import fmi4_common as fc

MODELS = list(fc.MODELS)


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    return fc.module_fmu(tmp_path_factory, "fmi4_bad")


@pytest.fixture(scope="module")
def starts(fmu):
    return fc.start_values(fmu[0])


@pytest.fixture
def log():
    return fc.LogCapture()


@pytest.fixture
def slaves(fmu):
    with fc.slave_factory(*fmu, "b") as new:
        yield new


SEQ = fc.input_sequence(400, seed=11)
WARM = 60          # steps before the bad call
AFTER = (WARM, WARM + 60)


NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def names_value(msg, v):
    """Whether the message prints the value v (any format, 6 significant digits suffice)."""
    low = msg.lower()
    if isinstance(v, float) and math.isnan(v):
        return re.search(r"(?<![a-z])nan(?![a-z])", low) is not None
    if isinstance(v, float) and math.isinf(v):
        pat = r"-\s*inf" if v < 0 else r"(?<!-)(?<![a-z])\+?inf"
        return re.search(pat, low) is not None
    for tok in NUMBER.findall(msg):
        x = float(tok)
        if x == v or abs(x - v) <= 1e-6 * abs(v):
            return True
    return False


def assert_error_logged(log, status, names, value=None, what=""):
    """status is fmi2Error and one error message names every name (and the value)."""
    assert status == fc.FMI2_ERROR, f"{what}: status {status}, expected fmi2Error (3)\n{log.text()}"
    errors = log.errors()
    assert errors, f"{what}: fmi2Error without a log message"

    def ok(msg):
        if not all(re.search(rf"(?<![A-Za-z0-9_]){re.escape(n)}(?![A-Za-z0-9_])", msg) for n in names):
            return False
        if value is None:
            return True
        return names_value(msg, value)

    assert any(ok(m) for m in errors), (
        f"{what}: no error message names {names}" + ("" if value is None else f" and the value {value!r}")
        + f"; got:\n  " + "\n  ".join(errors))


def stepping_pair(slaves, log, model="DDT"):
    """(s, twin, t): two instances with the same history; s logs to `log`."""
    s = slaves(model, fc.STATE_PARAMS, log=log)
    twin = slaves(model, fc.STATE_PARAMS)
    _, t = fc.drive(s, 0.0, SEQ, 0, WARM)
    _, t2 = fc.drive(twin, 0.0, SEQ, 0, WARM)
    assert t == t2
    return s, twin, t


def assert_unchanged(s, twin, t, what):
    """Same inputs, parameters and outputs as the twin, and the same run afterwards."""
    assert s.getReal(fc.IN_VRS) == twin.getReal(fc.IN_VRS), f"{what}: inputs changed"
    pv = list(fc.PARAMETER_VR.values())
    assert s.getReal(pv) == twin.getReal(pv), f"{what}: parameters changed"
    assert s.getInteger([fc.MODEL_VR]) == twin.getInteger([fc.MODEL_VR]), f"{what}: model changed"
    assert np.array_equal(fc.outputs(s), fc.outputs(twin)), f"{what}: outputs changed"
    Y, _ = fc.drive(s, t, SEQ, *AFTER)
    Yt, _ = fc.drive(twin, t, SEQ, *AFTER)
    assert np.array_equal(Y, Yt), f"{what}: the run after the bad call differs (max {np.max(np.abs(Y - Yt)):.3e})"


# --------------------------------------------------------------------------- non-finite inputs

@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf], ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize("name", fc.INPUTS)
def test_non_finite_input_is_refused(slaves, log, name, value):
    s, twin, t = stepping_pair(slaves, log)
    log.clear()
    status, _ = fc.status_of(s.setReal, [fc.INPUT_VR[name]], [value])
    assert_error_logged(log, status, [name], value, f"setReal {name} = {value}")
    assert_unchanged(s, twin, t, f"{name} = {value}")


def test_rejected_multi_value_set_changes_nothing(slaves, log):
    """A call with one bad value among good ones is refused as a whole."""
    s, twin, t = stepping_pair(slaves, log, "SecondOrder")
    for vrs, vals, names, bad in [
        ([2, 4, 5], [0.5, math.nan, 1000.0], ["vsx"], math.nan),
        # all five inputs in declared order (the path a co-simulation step takes)
        ([1, 2, 3, 4, 5], [3.0, 0.1, math.inf, 0.0, 900.0], ["steerRate"], math.inf),
        ([1, 2, 3, 4, 5], [3.0, 0.1, 0.0, 0.0, math.nan], ["Fz"], math.nan),
        ([1, 2, 999], [3.0, -0.4, 1.0], ["999"], None),
        ([3, 103], [0.1, 2.0], ["sigmaY"], 2.0),          # fixed parameter after init
    ]:
        log.clear()
        status, _ = fc.status_of(s.setReal, vrs, vals)
        assert_error_logged(log, status, names, bad, f"setReal {vrs} = {vals}")
    assert_unchanged(s, twin, t, "multi-value set")


# --------------------------------------------------------------------------- unknown references

@pytest.mark.parametrize("vr", [6, 10, 20, 99, 126, 999, 2**31, 2**32 - 1])
def test_unknown_value_reference_is_refused(slaves, log, vr):
    s, twin, t = stepping_pair(slaves, log)
    for call, args in [(s.setReal, ([vr], [1.0])), (s.getReal, ([vr],)),
                       (s.setInteger, ([vr], [1])), (s.getInteger, ([vr],))]:
        log.clear()
        status, _ = fc.status_of(call, *args)
        assert_error_logged(log, status, [str(vr)], None, f"{call.__name__} vr {vr}")
    assert_unchanged(s, twin, t, f"unknown vr {vr}")


def test_wrong_type_and_causality_are_refused(slaves, log):
    s, twin, t = stepping_pair(slaves, log)
    cases = [
        (s.setReal, ([fc.MODEL_VR], [1.0]), ["tireModel"]),             # Integer via setReal
        (s.setInteger, ([fc.PARAMETER_VR["Calpha"]], [1]), ["Calpha"]),  # Real via setInteger
        (s.setReal, ([fc.OUTPUT_VR["Fy"]], [1.0]), ["Fy"]),             # an output
        (s.setReal, ([0], [1.0]), ["time"]),                            # the independent variable
        (s.setBoolean, ([fc.INPUT_VR["vy"]], [True]), []),
        (s.setString, ([fc.INPUT_VR["vy"]], ["1"]), []),
    ]
    for call, args, names in cases:
        log.clear()
        status, _ = fc.status_of(call, *args)
        assert_error_logged(log, status, names, None, f"{call.__name__}{args}")
    assert_unchanged(s, twin, t, "wrong type")


# --------------------------------------------------------------------------- parameters

OUT_OF_RANGE = [
    ("sigmaY", 0.0), ("sigmaY", -1.0), ("sigmaX", 0.0), ("sigmaX", -0.5),
    ("Calpha", 0.0), ("Calpha", -5.0), ("Ckappa", 0.0), ("Ckappa", -5.0),
    ("dampingY", -1.0), ("dampingX", -1.0), ("dampingPsi", -1.0), ("carcassDampingY", -1.0),
    ("ringDampingY", -1.0), ("ringDampingX", -2.5), ("dampingY", -1e-9),
    ("contactMass", 0.0), ("contactMass", -1.0), ("ringMass", 0.0), ("ringMass", -1.0),
    ("ringInertia", 0.0), ("ringInertia", -1.0),
    ("sigmaPsi", 0.0), ("sigmaTread", 0.0), ("sigmaTread", -0.1), ("Re", 0.0), ("Fz0", 0.0),
    ("stiffnessPsi", -1.0), ("calphaLoadPeak", 0.0), ("calphaLoadPeak", -2.0),
    ("sigmaY", math.nan), ("Calpha", math.inf), ("contactMass", -math.inf),
    ("muX", -0.1), ("muY", -1.0), ("boreRadius", -0.01), ("muLoadSensitivity", math.nan),
    ("muY", math.inf),
]


@pytest.mark.parametrize("phase", ["instantiated", "initializationMode"])
@pytest.mark.parametrize("name,value", OUT_OF_RANGE, ids=[f"{n}={v}" for n, v in OUT_OF_RANGE])
def test_parameter_out_of_range_is_refused(slaves, log, starts, name, value, phase):
    model = "RingBody" if name.startswith("ring") or name in ("Re",) else (
        "SecondOrder" if name in ("contactMass", "carcassDampingY", "sigmaTread") else "DDT")
    good = {name: starts[name] * 1.25 + (0.0 if starts[name] else 0.5)}
    s = slaves(log=log, init=False)
    s.setupExperiment(startTime=0.0)
    s.setInteger([fc.MODEL_VR], [fc.MODELS[model]])
    vr = fc.ALL_PARAMETER_VR[name]
    s.setReal([vr], [good[name]])
    if phase == "initializationMode":
        s.enterInitializationMode()
    log.clear()
    status, _ = fc.status_of(s.setReal, [vr], [value])
    assert_error_logged(log, status, [name], value, f"{name} = {value} in {phase}")
    if phase == "instantiated":
        s.enterInitializationMode()
    assert s.getReal([vr]) == [good[name]], "the previous value was not kept"
    s.exitInitializationMode()
    Y, _ = fc.drive(s, 0.0, SEQ, 0, 50)
    fresh = slaves(model, good)
    Yf, _ = fc.drive(fresh, 0.0, SEQ, 0, 50)
    assert np.array_equal(Y, Yf)


@pytest.mark.parametrize("name", list(fc.ALL_PARAMETER_VR))
def test_fixed_parameter_after_initialisation_is_refused(slaves, log, starts, name):
    s, twin, t = stepping_pair(slaves, log, "RingBody")
    vr = fc.ALL_PARAMETER_VR[name]
    before = s.getReal([vr])
    value = before[0] * 1.5 + 0.25
    log.clear()
    status, _ = fc.status_of(s.setReal, [vr], [value])
    assert_error_logged(log, status, [name], value, f"{name} = {value} after initialisation")
    assert s.getReal([vr]) == before
    assert_unchanged(s, twin, t, f"fixed {name}")


@pytest.mark.parametrize("name", list(fc.ALL_PARAMETER_VR))
def test_fixed_parameter_set_to_its_value_after_initialisation_is_accepted(slaves, log, name):
    """docs/specification.md 8: importers such as the FMU Compliance Checker set every column of their input
    file, parameters included, before every step; the value in use is harmless."""
    s, twin, t = stepping_pair(slaves, log, "RingBody")
    vr = fc.ALL_PARAMETER_VR[name]
    before = s.getReal([vr])
    log.clear()
    status, _ = fc.status_of(s.setReal, [vr], before)
    assert status == fc.FMI2_OK, f"{name} = {before[0]} (its value) after initialisation: status {status}\n{log.text()}"
    assert not log.errors(), log.text()
    assert s.getReal([vr]) == before
    assert_unchanged(s, twin, t, f"{name} set to its own value")


def test_every_variable_set_to_its_value_before_every_step_runs_like_a_plain_run(slaves, log):
    """The FMU Compliance Checker's way: each step sets the inputs and every parameter and
    selector (at the values in use) in one call per type. The run equals one that sets only
    the inputs."""
    s, twin, t = stepping_pair(slaves, log, "DDT")
    parameter_vrs = list(fc.ALL_PARAMETER_VR.values())
    selector_vrs = [fc.MODEL_VR, fc.FRICTION_VR]
    parameters = s.getReal(parameter_vrs)
    selectors = s.getInteger(selector_vrs)
    for k in range(WARM, WARM + 40):
        inputs = [float(v) for v in SEQ["U"][k]]
        h = float(SEQ["h"][k])
        for instance in (s, twin):
            instance.setReal(fc.IN_VRS, inputs)
        assert fc.status_of(s.setReal, parameter_vrs, parameters)[0] == fc.FMI2_OK, log.text()
        assert fc.status_of(s.setInteger, selector_vrs, selectors)[0] == fc.FMI2_OK, log.text()
        for instance in (s, twin):
            instance.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
        assert np.array_equal(fc.outputs(s), fc.outputs(twin)), f"step {k}"
    assert not log.errors(), log.text()


# The two selectors: (name, value reference, the value the instance runs with, values
# to set after initialisation, values out of range, the value set before them, and the
# configuration a fresh twin needs to run like it).
SELECTORS = {
    "tireModel": (fc.MODEL_VR, fc.MODELS["SecondOrder"], [1, 2, 3, 4], [0, 5, -1, 99, -(2**31)],
                  fc.MODELS["RLT"], dict(model="RLT")),
    "friction": (fc.FRICTION_VR, fc.FRICTIONS["Brush"], [1, 2, 3], [0, 4, -1, 99, -(2**31)],
                 fc.FRICTIONS["Coulomb"], dict(model="DDT", friction="Coulomb")),
}
AFTER_INITIALISATION = [(n, v) for n, spec in SELECTORS.items() for v in spec[2]]
OUT_OF_RANGE_SELECTIONS = [(n, v) for n, spec in SELECTORS.items() for v in spec[3]]


@pytest.mark.parametrize("name,value", AFTER_INITIALISATION)
def test_selector_after_initialisation_is_refused_unless_unchanged(slaves, log, name, value):
    vr, running = SELECTORS[name][:2]
    model = "SecondOrder" if name == "tireModel" else "DDT"
    s, twin, t = stepping_pair(slaves, log, model)
    log.clear()
    status, _ = fc.status_of(s.setInteger, [vr], [value])
    if value == running:
        # The selection in use, set again (docs/specification.md 8): accepted, nothing changes.
        assert status == fc.FMI2_OK and not log.errors(), log.text()
    else:
        assert_error_logged(log, status, [name], float(value), f"{name} = {value} after initialisation")
    assert s.getInteger([vr]) == [running]
    assert_unchanged(s, twin, t, f"{name} = {value}")


@pytest.mark.parametrize("name,value", OUT_OF_RANGE_SELECTIONS)
def test_selector_out_of_range_is_refused(slaves, log, name, value):
    vr, _, _, _, chosen, twin_configuration = SELECTORS[name]
    s = slaves(log=log, init=False)
    s.setupExperiment(startTime=0.0)
    s.setInteger([vr], [chosen])
    log.clear()
    status, _ = fc.status_of(s.setInteger, [vr], [value])
    assert_error_logged(log, status, [name], float(value), f"{name} = {value}")
    s.enterInitializationMode()
    log.clear()
    status, _ = fc.status_of(s.setInteger, [vr], [value])
    assert_error_logged(log, status, [name], float(value), f"{name} = {value} in initialisation mode")
    assert s.getInteger([vr]) == [chosen]
    s.exitInitializationMode()
    Y, _ = fc.drive(s, 0.0, SEQ, 0, 40)
    Yf, _ = fc.drive(slaves(**twin_configuration), 0.0, SEQ, 0, 40)
    assert np.array_equal(Y, Yf)


# (model, parameters, the parameter the error names); the default friction law is Brush.
INCONSISTENT = [
    ("SecondOrder", {"sigmaTread": 1.0}, "sigmaTread"),        # == sigmaY
    ("SecondOrder", {"sigmaTread": 1.5}, "sigmaTread"),        # > sigmaY
    ("SecondOrder", {"sigmaY": 0.08}, "sigmaTread"),           # sigmaY below sigmaTread 0.1
    ("RingBody", {"sigmaTread": 1.5}, "sigmaTread"),
    ("RingBody", {"sigmaTread": 0.6}, "sigmaTread"),           # < sigmaY 1.0 but >= sigmaX 0.5
    ("RingBody", {"sigmaX": 0.1}, "sigmaTread"),               # == sigmaTread
    # One ellipse, a damped and an undamped direction: the slider law needs both alike.
    ("DDT", {"dampingX": 0.0}, "dampingX"),
    ("DDT", {"dampingY": 0.0}, "dampingY"),
]


@pytest.mark.parametrize("model,params,named", INCONSISTENT, ids=[f"{m}-{p}" for m, p, _ in INCONSISTENT])
def test_inconsistent_parameters_fail_exit_initialisation(slaves, log, starts, model, params, named):
    s = slaves(log=log, init=False)
    s.setupExperiment(startTime=0.0)
    s.setInteger([fc.MODEL_VR], [fc.MODELS[model]])
    s.setReal([fc.PARAMETER_VR[k] for k in params], list(params.values()))
    s.enterInitializationMode()
    log.clear()
    status, _ = fc.status_of(s.exitInitializationMode)
    assert_error_logged(log, status, [named], None, f"{model} with {params}")
    # not initialised: a step is refused
    status, _ = fc.status_of(s.doStep, 0.0, 0.01)
    assert status == fc.FMI2_ERROR
    # recovery 1: fix the parameter and exit again
    s.setReal([fc.PARAMETER_VR[k] for k in params], [starts[k] for k in params])
    s.exitInitializationMode()
    Y, _ = fc.drive(s, 0.0, SEQ, 0, 40)
    Yf, _ = fc.drive(slaves(model), 0.0, SEQ, 0, 40)
    assert np.array_equal(Y, Yf)


def test_inconsistent_parameters_recover_by_reset(slaves, log):
    s = slaves(log=log, init=False)
    s.setupExperiment(startTime=0.0)
    s.setInteger([fc.MODEL_VR], [fc.MODELS["SecondOrder"]])
    s.setReal([fc.PARAMETER_VR["sigmaTread"]], [2.0])
    s.enterInitializationMode()
    status, _ = fc.status_of(s.exitInitializationMode)
    assert status == fc.FMI2_ERROR
    s.reset()
    fc.initialise(s, "SecondOrder")
    Y, _ = fc.drive(s, 0.0, SEQ, 0, 40)
    Yf, _ = fc.drive(slaves("SecondOrder"), 0.0, SEQ, 0, 40)
    assert np.array_equal(Y, Yf)


# --------------------------------------------------------------------------- lift-off

@pytest.mark.parametrize("Fz", [0.0, -100.0, -0.0, 1e-300 * -1])
@pytest.mark.parametrize("model", MODELS)
def test_zero_or_negative_load_is_not_an_error(slaves, log, model, Fz):
    s = slaves(model, None, dict(vx=3.0, vy=0.3, steerRate=0.2, vsx=0.1), log=log)
    t = 0.0
    for _ in range(50):
        s.doStep(t, 0.01)
        t += 0.01
    d0 = np.abs(fc.outputs(s)[4:])
    assert np.any(d0 > 1e-3)
    log.clear()
    s.setReal([fc.INPUT_VR["Fz"]], [Fz])                      # raises on fmi2Error
    assert not log.errors(), log.text()
    loads = [fc.OUTPUTS.index(n) for n in ("Fx", "Fy", "Mz", "My")]
    defl = [fc.OUTPUTS.index(n) for n in ("deflX", "deflY", "deflPsi", "alphaT", "kappaT")]
    y = fc.outputs(s)
    assert np.all(y[loads] == 0.0), f"forces with Fz = {Fz}: {y[loads]}"
    prev = np.abs(y[defl])
    for _ in range(30):
        s.doStep(t, 0.01)
        t += 0.01
        y = fc.outputs(s)
        assert np.all(y[loads] == 0.0)
        cur = np.abs(y[defl])
        assert np.all(cur <= prev), "deflections must relax while lifted off"
        prev = cur
    assert np.all(prev <= 1e-3 * np.max(d0) + 1e-12), f"deflections did not relax: {prev}"
    assert not log.errors(), log.text()
    # loaded again: forces come back
    s.setReal([fc.INPUT_VR["Fz"]], [50000.0])
    s.setReal([fc.INPUT_VR["vy"]], [0.3])
    s.doStep(t, 0.05)
    assert np.any(fc.outputs(s)[loads] != 0.0)


# --------------------------------------------------------------------------- recovery

def _bad_calls(s, t, blob):
    """Calls that must each return fmi2Error, as (label, callable)."""
    bad = bytearray(blob)
    bad[len(bad) // 2] ^= 0x01
    return [
        ("nan input", lambda: s.setReal([fc.INPUT_VR["vy"]], [math.nan])),
        ("unknown vr", lambda: s.setReal([12345], [1.0])),
        ("fixed parameter", lambda: s.setReal([fc.PARAMETER_VR["sigmaY"]], [3.0])),
        ("tireModel", lambda: s.setInteger([fc.MODEL_VR], [1])),
        ("corrupt state", lambda: s.deSerializeFMUstate(bytes(bad))),
        ("truncated state", lambda: s.deSerializeFMUstate(blob[:-3])),
        ("step <= 0", lambda: s.doStep(t, 0.0)),
        ("negative step", lambda: s.doStep(t, -0.01)),
        ("nan step", lambda: s.doStep(t, math.nan)),
        ("wrong time", lambda: s.doStep(t + 0.5, 0.01)),
        ("cancelStep", lambda: s.cancelStep()),
        ("output derivative order 2", lambda: s.getRealOutputDerivatives([fc.OUTPUT_VR["Fy"]], [2])),
        ("input derivative of an output", lambda: s.setRealInputDerivatives([fc.OUTPUT_VR["Fy"]], [1], [1.0])),
        ("input derivative order 2", lambda: s.setRealInputDerivatives([fc.INPUT_VR["vy"]], [2], [1.0])),
        ("nan input derivative", lambda: s.setRealInputDerivatives([fc.INPUT_VR["vy"]], [1], [math.nan])),
        ("directional derivative wrt parameter",
         lambda: s.getDirectionalDerivative([fc.OUTPUT_VR["Fy"]], [fc.PARAMETER_VR["sigmaY"]], [1.0])),
        ("enter initialisation again", lambda: s.enterInitializationMode()),
    ]


N_BAD = 17


@pytest.mark.parametrize("k", range(N_BAD))
def test_recovery_after_error_by_set_state_and_by_reset(slaves, log, k):
    s, twin, t = stepping_pair(slaves, log, "RingBody")
    state = s.getFMUstate()
    blob = s.serializeFMUstate(state)
    calls = _bad_calls(s, t, blob)
    assert len(calls) == N_BAD
    label, call = calls[k]
    log.clear()
    status, _ = fc.status_of(call)
    assert status == fc.FMI2_ERROR, f"{label}: status {status}"
    assert log.errors(), f"{label}: no error message"
    # the instance is unchanged and still steps
    assert np.array_equal(fc.outputs(s), fc.outputs(twin)), label
    # 1) restore with fmi2SetFMUstate and run on like the twin
    s.setFMUstate(state)
    s.freeFMUstate(state)
    Y, _ = fc.drive(s, t, SEQ, *AFTER)
    Yt, _ = fc.drive(twin, t, SEQ, *AFTER)
    assert np.array_equal(Y, Yt), f"{label}: run after setFMUstate differs"
    # 2) another error, then fmi2Reset: as good as a fresh instance
    fc.status_of(_bad_calls(s, 0.0, blob)[k][1])
    s.reset()
    fc.initialise(s, "RLT")
    Y, _ = fc.drive(s, 0.0, SEQ, 0, 50)
    Yf, _ = fc.drive(slaves("RLT"), 0.0, SEQ, 0, 50)
    assert np.array_equal(Y, Yf), f"{label}: run after reset differs"


# --------------------------------------------------------------------------- status functions

def test_cancel_step_is_always_an_error(slaves, log):
    s = slaves(log=log, init=False)
    phases = []
    log.clear()
    phases.append(("instantiated", fc.status_of(s.cancelStep)[0]))
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    phases.append(("initializationMode", fc.status_of(s.cancelStep)[0]))
    s.exitInitializationMode()
    phases.append(("step mode, before a step", fc.status_of(s.cancelStep)[0]))
    s.doStep(0.0, 0.01)
    phases.append(("step mode, after a step", fc.status_of(s.cancelStep)[0]))
    s.terminate()
    phases.append(("terminated", fc.status_of(s.cancelStep)[0]))
    assert all(st == fc.FMI2_ERROR for _, st in phases), phases
    assert len(log.errors()) >= len(phases)
    assert all("CancelStep" in m for m in log.errors())


def test_status_functions_in_step_mode(slaves, log):
    s = slaves("DDT", None, dict(vx=4.0, vy=0.1), log=log)
    t = 0.0
    for h in [0.01, 0.003, 0.25, 1e-6, 0.5]:
        s.doStep(t, h)
        t += h
        assert s.getStatus(0) == fc.FMI2_OK                      # fmi2DoStepStatus
        assert s.getRealStatus(2) == pytest.approx(t, rel=1e-15, abs=1e-15)  # fmi2LastSuccessfulTime
        assert s.getBooleanStatus(3) is False                   # fmi2Terminated
    log.clear()
    # no asynchronous step: fmi2PendingStatus is not available -> fmi2Discard
    assert fc.status_of(s.getStringStatus, 1)[0] == fc.FMI2_DISCARD
    # kinds a function does not provide: fmi2Discard (status information not available)
    for call, kind in [(s.getIntegerStatus, 0), (s.getIntegerStatus, 2), (s.getRealStatus, 0),
                       (s.getBooleanStatus, 0), (s.getStatus, 2)]:
        st, _ = fc.status_of(call, kind)
        assert st in (fc.FMI2_DISCARD, fc.FMI2_ERROR), f"{call.__name__}({kind}) returned {st}"
    assert not log.errors() or all("Status" in m for m in log.errors()), log.text()
    # a status query changes nothing
    twin = slaves("DDT", None, dict(vx=4.0, vy=0.1))
    tt = 0.0
    for h in [0.01, 0.003, 0.25, 1e-6, 0.5]:
        twin.doStep(tt, h)
        tt += h
    assert np.array_equal(fc.outputs(s), fc.outputs(twin))


def test_last_successful_time_after_restore_and_reset(slaves):
    s = slaves("RLT")
    s.doStep(0.0, 0.4)
    st = s.getFMUstate()
    s.doStep(0.4, 0.6)
    assert s.getRealStatus(2) == pytest.approx(1.0, abs=1e-15)
    s.setFMUstate(st)
    s.freeFMUstate(st)
    assert s.getRealStatus(2) == 0.4
    s.reset()
    fc.initialise(s, "RLT", start_time=2.0)
    assert s.getRealStatus(2) == 2.0
    s.doStep(2.0, 0.5)
    assert s.getRealStatus(2) == 2.5


def test_status_functions_after_terminate(slaves, log):
    """FMI 2.0 (state-machine table of section 4.2.4, as in the Modelica Reference FMUs'
    MASK_fmi2GetStatus) allows fmi2GetStatus and fmi2Get*Status in state terminated; the
    last successful time is then the time the simulation ended."""
    s = slaves("DDT", log=log)
    s.doStep(0.0, 0.25)
    s.terminate()
    log.clear()
    st, value = fc.status_of(s.getRealStatus, 2)
    assert st == fc.FMI2_OK, f"fmi2GetRealStatus(fmi2LastSuccessfulTime) after terminate: status {st}\n{log.text()}"
    assert value == 0.25
    st, value = fc.status_of(s.getBooleanStatus, 3)
    assert st == fc.FMI2_OK, f"fmi2GetBooleanStatus(fmi2Terminated) after terminate: status {st}\n{log.text()}"
    st, value = fc.status_of(s.getStatus, 0)
    assert st == fc.FMI2_OK, f"fmi2GetStatus(fmi2DoStepStatus) after terminate: status {st}\n{log.text()}"


def test_step_past_stop_time_is_refused(slaves, log):
    s = slaves(log=log, init=False)
    s.setupExperiment(startTime=0.0, stopTime=1.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    s.setReal(fc.IN_VRS, [5.0, 0.2, 0.1, 0.05, 50000.0])
    t = 0.0
    for _ in range(9):
        s.doStep(t, 0.1)
        t += 0.1
    y = fc.outputs(s)
    log.clear()
    status, _ = fc.status_of(s.doStep, t, 0.2)
    assert_error_logged(log, status, ["stopTime"], None, "step past stopTime")
    assert np.array_equal(fc.outputs(s), y)
    assert s.getRealStatus(2) == t
    s.doStep(t, 0.1)        # ends at stopTime (within rounding): accepted
