"""The FMI 3.0 FMU (docs/specification.md 7c), driven by fmpy.

target/fmu/fmi3/TireLag.fmu is the same library as the FMI 2.0 FMU with FMI 3.0
Co-Simulation and Model Exchange. These tests hold it to the FMI 2.0 FMU and to the
FMI 3.0 contract:

1. Model description: fmpy's validate_fmu finds no problem; the same variables as the
   FMI 2.0 model description (name, value reference, causality, variability, initial,
   start, min, max, unit, nominal, derivative), Real -> Float64 and the two selectors as
   Enumerations; 18 ContinuousStateDerivatives and 9 EventIndicators in the documented
   order; the declared capabilities; the binary is the FMI 2.0 FMU's, byte for byte.
2. Co-Simulation equals the FMI 2.0 FMU, both driven step by step with the same
   piecewise-constant inputs (FMU2Slave without input derivatives, FMU3Slave), to 1e-9 of
   each output's friction scale (output_scales), every model and friction law, on a
   sequence that slides at standstill and reverses, reverses vx, lifts off and varies the
   step; and fmpy.simulate_fmu(fmi_type="CoSimulation") runs the FMI 3.0 FMU and equals
   the FMI 2.0 one on a standstill push.
3. Model Exchange: fmpy.simulate_fmu(fmi_type="ModelExchange", solver="CVode",
   relative_tolerance=1e-10) equals the exact Co-Simulation step (fmpy simulate_fmu,
   CoSimulation, on the FMI 3.0 FMU) within 1e-3 of the friction scale on
   test_model_exchange.slip_steps (lateral and longitudinal slip steps into saturation,
   across and back), every model and law, with the event count printed and bounded; fmpy's
   forward Euler (1e-4 s) runs one case within test_model_exchange.EULER_TOLERANCE.
4. FMU state: get/set in process, serialize/deserialize into another instance and into
   another process (fmi3_state_worker.py) continue bit-identically, Co-Simulation and
   Model Exchange; bad serialized states are refused.
5. Bad input: non-finite and out-of-range inputs, unknown value references, wrong types,
   the wrong call sequence, refused instantiations and every unsupported function return
   fmi3Error (or NULL) with a message, and change nothing.
6. Logging: the FMI 3.0 logMessage callback gets the errors (category logStatusError) as
   plain text ('%' once, never '%%'); fmi3SetDebugLogging(logAll) traces the calls.

Force scale ("Fmax"): test_model_exchange.force_scales of the parameters in use, at the
load the inputs hold: Fx Fmax_x = muX(Fz) Fz, Fy Fmax_y = muY(Fz) Fz, Mz the yaw limit
boreRadius muY(Fz) Fz plus trail Fmax_y, My Re Fmax_x. The same scale is used for the
Unlimited law (the linear tire): its forces are larger, so the bound is tighter relative
to them. Deflections and transient slips are scaled by the elastic travel at that limit
(output_scales).
"""

from __future__ import annotations

import ctypes
import json
import math
import zipfile
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import fmi3_common as f3
import fmi3_state_worker as worker3
import fmi4_common as fc
import friction_reference as fr
import test_model_exchange as tme
from test_bad_input import assert_error_logged

MODELS = list(fc.MODELS)
LAWS = ["Unlimited", "Coulomb", "Brush"]
FX, FY, MZ, MY = range(4)

P = ctypes.POINTER
U32 = ctypes.c_uint32
SIZE = ctypes.c_size_t
VOID = ctypes.c_void_p


# --------------------------------------------------------------------------- fixtures

@pytest.fixture(scope="module")
def fmu3(tmp_path_factory):
    """(model description, unzip directory) of the FMI 3.0 FMU."""
    if not f3.FMU3_PATH.is_file():
        pytest.fail(f"FMI 3.0 FMU not found: {f3.FMU3_PATH} (build it with ./scripts/build-fmu)")
    return f3.read_md3(), f3.extract_fmu3(tmp_path_factory.mktemp("fmi3"))


@pytest.fixture(scope="module")
def fmu2(tmp_path_factory):
    """(model description, unzip directory) of the FMI 2.0 FMU."""
    return fc.module_fmu(tmp_path_factory, "fmi3_vs_fmi2")


@pytest.fixture
def new3(fmu3):
    """new3(model, params, inputs, log, init, friction, me) -> FMI 3.0 instance, freed after the test."""
    with f3.instance_factory3(*fmu3, "t") as new:
        yield new


@pytest.fixture
def new2(fmu2):
    """new2(model, params, inputs, log, init, friction) -> FMU2Slave, freed after the test."""
    with fc.slave_factory(*fmu2, "t2_") as new:
        yield new


def fmu3_xml():
    with zipfile.ZipFile(f3.FMU3_PATH) as zf:
        return ET.fromstring(zf.read("modelDescription.xml"))


# --------------------------------------------------------------------------- 1. model description

def test_fmu_validates():
    """fmpy's validate_fmu (XML schema, names, ModelStructure, start values, causality and
    variability, units) finds no problem."""
    from fmpy.validation import validate_fmu

    problems = validate_fmu(str(f3.FMU3_PATH))
    assert problems == [], "\n".join(problems)


def test_interfaces_capabilities_and_binary(fmu3, fmu2):
    """FMI 3.0, instantiationToken = the FMI 2.0 guid, Co-Simulation and Model Exchange
    (no Scheduled Execution) with modelIdentifier TireLag and the capabilities of the
    FMI 3.0 interface; the same log categories and default experiment as the FMI 2.0 FMU;
    binaries/x86_64-linux/TireLag.so is the FMI 2.0 FMU's binaries/linux64/TireLag.so."""
    md3, _ = fmu3
    md2, _ = fmu2
    root = fmu3_xml()
    assert root.get("fmiVersion", "").startswith("3.0"), root.get("fmiVersion")
    assert root.get("instantiationToken") == md2.guid == "{6b1f6a52-8c3e-4f0e-9d2a-5e7c1b9a4d31}"
    assert md3.guid == md2.guid
    cs, me = root.find("CoSimulation"), root.find("ModelExchange")
    assert cs is not None and me is not None
    assert root.find("ScheduledExecution") is None
    for element, expected in [
        (cs, {"modelIdentifier": "TireLag", "canHandleVariableCommunicationStepSize": "true",
              "maxOutputDerivativeOrder": "1", "canGetAndSetFMUState": "true",
              "canSerializeFMUState": "true", "providesDirectionalDerivatives": "true"}),
        (me, {"modelIdentifier": "TireLag", "canGetAndSetFMUState": "true",
              "canSerializeFMUState": "true", "providesDirectionalDerivatives": "true"}),
    ]:
        got = {k: element.get(k) for k in expected}
        assert got == expected, (element.tag, got)
    assert cs.get("hasEventMode", "false") == "false", cs.get("hasEventMode")
    assert me.get("needsCompletedIntegratorStep", "false") == "false"
    assert not md3.modelExchange.needsCompletedIntegratorStep
    assert [c.name for c in md3.logCategories] == [c.name for c in md2.logCategories] == [
        "logStatusError", "logStatusWarning", "logAll"]
    e2, e3 = md2.defaultExperiment, md3.defaultExperiment
    assert [float(getattr(e3, k)) for k in ("startTime", "stopTime", "tolerance", "stepSize")] == \
           [float(getattr(e2, k)) for k in ("startTime", "stopTime", "tolerance", "stepSize")]
    with zipfile.ZipFile(f3.FMU3_PATH) as z3, zipfile.ZipFile(fc.FMU_PATH) as z2:
        assert f3.BINARY3 in z3.namelist(), z3.namelist()
        assert z3.read(f3.BINARY3) == z2.read("binaries/linux64/TireLag.so"), \
            "the FMI 3.0 FMU's library differs from the FMI 2.0 FMU's"


FMI3_TYPE = {"Real": "Float64", "Integer": "Enumeration", "String": "String"}
SELECTOR_TYPES = {"tireModel": ("TireLagModel", [("RLT", 1), ("DDT", 2), ("SecondOrder", 3), ("RingBody", 4)]),
                  "friction": ("TireFriction", [("Unlimited", 1), ("Coulomb", 2), ("Brush", 3)])}


def _bound(v, which):
    """min or max of a variable, else of its declared type, else (enumerations) of its items."""
    value = getattr(v, which)
    t = v.declaredType
    if value is None and t is not None:
        value = getattr(t, which)
    if value is None and t is not None and t.items:
        values = [int(i.value) for i in t.items]
        value = min(values) if which == "min" else max(values)
    return None if value is None else float(value)


def _attributes(v):
    unit = v.unit if v.unit is not None else (v.declaredType.unit if v.declaredType is not None else None)
    start = v.start
    if v.type not in ("String",) and start is not None:
        start = float(start)
    return {
        "valueReference": v.valueReference, "causality": v.causality, "variability": v.variability,
        "initial": v.initial, "start": start, "min": _bound(v, "min"), "max": _bound(v, "max"),
        "unit": unit, "nominal": None if v.nominal is None else float(v.nominal),
        "derivative": None if v.derivative is None else v.derivative.name,
    }


def test_variables_match_fmi2(fmu3, fmu2):
    """Every variable of the FMI 2.0 model description, and no other, with the same name,
    value reference, causality, variability, initial, start, min, max, unit, nominal and
    derivative (numbers compared as numbers); Real -> Float64, String -> String, the two
    Integer selectors -> Enumeration of TireLagModel (RLT=1 .. RingBody=4) and
    TireFriction (Unlimited=1, Coulomb=2, Brush=3). The outputs of ModelStructure are the
    same, in the same order, with the same dependencies. `time` (vr 0) is the
    independent variable of both."""
    md3, _ = fmu3
    md2, _ = fmu2
    v2 = {v.name: v for v in md2.modelVariables}
    v3 = {v.name: v for v in md3.modelVariables}
    assert len(v3) == len(md3.modelVariables), "duplicate names"
    assert sorted(v3) == sorted(v2), (f"only in FMI 3: {sorted(set(v3) - set(v2))}; "
                                      f"only in FMI 2: {sorted(set(v2) - set(v3))}")
    differences = []
    for name, a in v2.items():
        b = v3[name]
        if b.type != FMI3_TYPE[a.type]:
            differences.append(f"{name}: type {b.type}, expected {FMI3_TYPE[a.type]} (FMI 2 {a.type})")
        attrs2, attrs3 = _attributes(a), _attributes(b)
        for key in attrs2:
            if attrs2[key] != attrs3[key]:
                differences.append(f"{name}: {key} FMI 3 {attrs3[key]!r}, FMI 2 {attrs2[key]!r}")
    assert not differences, "\n".join(differences)
    for name, (type_name, items) in SELECTOR_TYPES.items():
        t = v3[name].declaredType
        assert t is not None and t.name == type_name, (name, t)
        assert [(i.name, int(i.value)) for i in t.items] == items, (name, t.items)
    assert v3["time"].valueReference == f3.TIME_VR and v3["time"].causality == "independent"
    assert v3["time"].type == "Float64"
    assert [u.variable.name for u in md3.outputs] == [u.variable.name for u in md2.outputs] == fc.OUTPUTS

    def deps(u):
        return None if u.dependencies is None else sorted(d.name for d in u.dependencies)

    assert [deps(u) for u in md3.outputs] == [deps(u) for u in md2.outputs]


def test_state_derivatives_and_event_indicators(fmu3, new3):
    """ModelStructure: 18 ContinuousStateDerivatives der(tireState1..6),
    der(sliderOffsetX1..4, Y1..4, Psi1..4) (vr 300-305, 310-321), each the derivative of
    its state (vr 200-205, 210-221), and 9 EventIndicators guardPlanar1..4, guardYaw1..4,
    guardLoad (vr 400-408, local continuous Float64), in this order; an ME instance reports
    the same numbers (fmi3GetNumberOfContinuousStates / EventIndicators) and 18 positive
    nominals."""
    md3, _ = fmu3
    assert md3.numberOfContinuousStates == f3.N_STATES
    assert md3.numberOfEventIndicators == f3.N_INDICATORS
    assert [u.variable.valueReference for u in md3.derivatives] == f3.DERIVATIVE_VRS
    assert [u.variable.name for u in md3.derivatives] == [f"der({n})" for n in f3.STATE_NAMES]
    assert [u.variable.derivative.valueReference for u in md3.derivatives] == f3.STATE_VRS
    assert [u.variable.derivative.name for u in md3.derivatives] == f3.STATE_NAMES
    assert [u.variable.valueReference for u in md3.eventIndicators] == f3.INDICATOR_VRS
    assert [u.variable.name for u in md3.eventIndicators] == f3.INDICATOR_NAMES
    for u in md3.eventIndicators:
        v = u.variable
        assert (v.type, v.causality, v.variability) == ("Float64", "local", "continuous"), v.name
    fmu = new3("SecondOrder", me=True)
    assert fmu.getNumberOfContinuousStates() == f3.N_STATES
    assert fmu.getNumberOfEventIndicators() == f3.N_INDICATORS
    nominals = (ctypes.c_double * f3.N_STATES)()
    fmu.getNominalsOfContinuousStates(nominals, f3.N_STATES)
    assert all(math.isfinite(v) and v > 0.0 for v in nominals), list(nominals)


def test_state_derivative_indicator_and_time_variables_read_what_the_functions_give(new3):
    """fmi3GetFloat64 of the 18 state variables, their 18 derivative variables and the 9
    event-indicator variables equals fmi3GetContinuousStates,
    fmi3GetContinuousStateDerivatives and fmi3GetEventIndicators (==), at a state set by
    fmi3SetContinuousStates away from rest (SecondOrder, Brush, Model Exchange: nonzero
    derivatives, a planar guard at or below 0);
    `time` reads the time of fmi3SetTime (ME) and the end of the last step (CS)."""
    fmu = new3("SecondOrder", fc.STATE_FRICTION_PARAMS, friction="Brush", me=True,
               inputs=dict(vx=2.0, vy=0.3, steerRate=0.1, vsx=-0.2, Fz=40000.0))
    x, dx, z = (ctypes.c_double * f3.N_STATES)(), (ctypes.c_double * f3.N_STATES)(), \
        (ctypes.c_double * f3.N_INDICATORS)()
    fmu.setTime(0.75)
    fmu.getContinuousStates(x, f3.N_STATES)
    x[0], x[1], x[2], x[3] = 1e-3, 2e-3, 0.05, -4e-4
    fmu.setContinuousStates(x, f3.N_STATES)
    fmu.getContinuousStates(x, f3.N_STATES)
    fmu.getContinuousStateDerivatives(dx, f3.N_STATES)
    fmu.getEventIndicators(z, f3.N_INDICATORS)
    assert fmu.getFloat64(f3.STATE_VRS) == list(x)
    assert fmu.getFloat64(f3.DERIVATIVE_VRS) == list(dx)
    assert fmu.getFloat64(f3.INDICATOR_VRS) == list(z)
    assert any(v != 0.0 for v in dx) and any(v <= 0.0 for v in list(z)[:4]), (list(dx), list(z))
    assert fmu.getFloat64([f3.TIME_VR]) == [0.75]
    cs = new3("DDT")
    _, t = f3.drive3(cs, 0.0, STATE_SEQ, 0, 30)
    assert cs.getFloat64([f3.TIME_VR]) == [t]


# --------------------------------------------------------------------------- 2. CS equals FMI 2.0

CS_PARAMS = {**fc.STATE_PARAMS, **fc.STATE_FRICTION_PARAMS}   # muY 0.3: slides (Unlimited ignores mu)
CS_FZ = 50000.0                                               # the sequence's load (its largest)
CS_SEQ = f3.concatenate(f3.standstill_reversal(Fz=CS_FZ), f3.piecewise_sequence(440, seed=23))
CS_STANDSTILL = slice(0, 160)                                 # the standstill push and reversal
CS_TOLERANCE = 1e-9                                           # of each output's scale


def output_scales(p, Fz):
    """The scale of each of the 9 outputs: the loads' friction scales
    (test_model_exchange.force_scales: Fmax_x, Fmax_y, yaw limit + trail Fmax_y,
    Re Fmax_x) and, for the deflections and transient slips, the elastic travel at those
    limits: deflX Fmax_x/C_x, deflY Fmax_y/C_y, deflPsi yaw limit/stiffnessPsi,
    kappaT deflX/sigmaX, alphaT deflY/sigmaY (C_x = Ckappa/sigmaX, C_y = Calpha/sigmaY)."""
    loads = tme.force_scales(p, Fz)
    lim = fr.limits(p, Fz)
    defl_x = lim["x"] / (p["Ckappa"] / p["sigmaX"])
    defl_y = lim["y"] / (p["Calpha"] / p["sigmaY"])
    defl_psi = lim["psi"] / p["stiffnessPsi"]
    return np.array([*loads, defl_y / p["sigmaY"], defl_x / p["sigmaX"], defl_x, defl_y, defl_psi])


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("model", MODELS)
def test_cosimulation_equals_fmi2(new2, new3, model, law):
    """FMU3Slave and FMU2Slave, same parameters (muY 0.3, muX 0.25: low friction), same
    piecewise-constant inputs (no input derivatives on FMI 2.0) and steps: the standstill
    push and reversal (fmi3_common.standstill_reversal: 0.4 m and 0.32 rad each way),
    then fmi4_common.input_sequence's values (vx through 0 and reversed, lift-off, a load
    ramp, steps of 1 to 50 ms). All nine outputs at t = 0 and after every step agree
    within 1e-9 of output_scales (measured: bit identical, the same library); every
    fmi3DoStep returns the flags of an FMU without event mode and lastSuccessfulTime =
    t + h (fmi3_common.drive3). The run slides: with friction Fy
    reaches -Fmax_y and then +Fmax_y at standstill (to 1e-6), and RLT and DDT (hub force =
    element force) never exceed Fmax_y; the linear tire passes 2 Fmax_y."""
    s2 = new2(model, CS_PARAMS, friction=law)
    s3 = new3(model, CS_PARAMS, friction=law)
    y2, y3 = fc.outputs(s2), f3.outputs3(s3)
    Y2, t2 = fc.drive(s2, 0.0, CS_SEQ)
    Y3, t3 = f3.drive3(s3, 0.0, CS_SEQ)
    assert t3 == t2
    assert not s3.log.errors(), s3.log.text()
    Y2, Y3 = np.vstack([y2, Y2]), np.vstack([y3, Y3])
    scales = output_scales(fr.parameters(**CS_PARAMS), CS_FZ)
    err = np.abs(Y3 - Y2) / scales
    worst = np.unravel_index(np.argmax(err), err.shape)
    print(f"\n{model} {law}: max |FMI3 - FMI2| = {err.max():.3g} of the scale "
          f"({fc.OUTPUTS[worst[1]]}, row {worst[0]}); bit identical: {np.array_equal(Y2, Y3)}")
    assert np.all(np.isfinite(Y3))
    assert err.max() <= CS_TOLERANCE, (
        f"{fc.OUTPUTS[worst[1]]} after step {worst[0]}: FMI 3 {Y3[worst]!r}, FMI 2 {Y2[worst]!r}")
    Fmax = fr.limits(fr.parameters(**CS_PARAMS), CS_FZ)["y"]
    fy = Y2[1:, FY]
    standstill = fy[CS_STANDSTILL] / Fmax
    if law == "Unlimited":
        assert np.abs(fy).max() > 2.0 * Fmax, np.abs(fy).max() / Fmax
        return
    assert standstill.min() <= -(1.0 - tme.PLATEAU_TOLERANCE), standstill.min()
    assert standstill.max() >= 1.0 - tme.PLATEAU_TOLERANCE, standstill.max()
    if model in ("RLT", "DDT"):
        assert np.abs(fy).max() <= Fmax * (1.0 + 1e-9), np.abs(fy).max() / Fmax


def test_simulate_fmu_cosimulation_runs_and_equals_fmi2(fmu3, fmu2):
    """fmpy.simulate_fmu(fmi_type="CoSimulation") on the FMI 3.0 FMU
    (test_model_exchange.run_cs: variable steps ending at every input jump and every
    10 ms) runs test_model_exchange.standstill_push (DDT, Brush, muY 0.05) and equals the
    same call on the FMI 2.0 FMU (without input derivatives) at every recorded time within
    1e-9 of the friction scale; the force saturates: Fy sits on -Fmax_y during the push and
    on +Fmax_y after the reversal (to 1e-6)."""
    case = tme.standstill_push("DDT", "Brush")
    r3 = tme.run_cs(*fmu3, case)
    r2 = tme.run_cs(*fmu2, case)
    assert len(r3) == len(r2) > 100
    assert np.array_equal(r3["time"], r2["time"])
    Y3 = np.column_stack([r3[n] for n in tme.LOADS])
    Y2 = np.column_stack([r2[n] for n in tme.LOADS])
    err = np.abs(Y3 - Y2) / case.scales
    print(f"\nsimulate_fmu CS: {len(r3)} samples, max |FMI3 - FMI2| = {err.max():.3g} of the friction scale")
    assert np.all(np.isfinite(Y3)) and err.max() <= CS_TOLERANCE
    t, Fmax = r3["time"], case.limits["y"]
    first = (t >= 0.45) & (t < tme.PUSH_TIME - 1e-9)
    second = t >= tme.PUSH_TIME + tme.RETURN_TIME - 0.1 - 1e-9
    assert first.sum() >= 10 and second.sum() >= 10
    assert np.abs(Y3[first, FY] + Fmax).max() <= tme.PLATEAU_TOLERANCE * Fmax
    assert np.abs(Y3[second, FY] - Fmax).max() <= tme.PLATEAU_TOLERANCE * Fmax


# --------------------------------------------------------------------------- 3. Model Exchange

def run_me3(md, unzipdir, case, solver):
    """fmpy simulate_fmu, Model Exchange, on the FMI 3.0 FMU through an FMU3CountingModel
    (as test_model_exchange.run_me). Returns (result, fmi3EnterEventMode calls, seconds)."""
    fmu = f3.new_model3(md, unzipdir, name=f"me3-{case!r}")
    result, seconds = tme.simulate_me(md, unzipdir, case, solver, fmu)
    assert not fmu.log.errors(), fmu.log.text()
    return result, fmu.n_events, seconds


def compare3(case, solver, md, unzipdir):
    """test_model_exchange.compare on the FMI 3.0 FMU: ME (solver) against CS (both
    through fmpy simulate_fmu), the event bound and the agreement on the 10 ms grid (input
    jump times left out). Returns (t, ME loads, CS loads)."""
    return tme.compare(case, solver, md, unzipdir, run=run_me3, label="FMI 3 ", events_cover_jumps=True)


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("model", MODELS)
def test_model_exchange_cvode_matches_cosimulation(fmu3, model, law):
    """test_model_exchange.slip_steps (vx = 10 m/s; vy +0.3, 0, -0.3, +0.3 m/s then vsx
    -0.4, 0, +0.4, -0.4 m/s, 0.15 s each, 4.2 times the limits of muY 0.05, muX 0.06):
    CVode at rtol 1e-10 equals the exact CS step within 1e-3 Fmax (ME_TOLERANCE) on Fx,
    Fy, Mz, My every 10 ms; at least one event per input jump (8) and at most
    Case.event_bound (Unlimited: exactly the jumps; friction: plus four switches per
    stick/slide group and phase). It saturates: with friction |Fx| and |Fy| reach their
    limits (to 1e-9 in CS, 1e-3 in ME), RLT and DDT never pass them; Unlimited passes 3
    times them."""
    case = tme.slip_steps(model, law)
    _, Y_me, Y_cs = compare3(case, "CVode", *fmu3)
    tme.assert_saturates(case, Y_me, Y_cs, tme.ME_TOLERANCE)


def test_model_exchange_euler_runs(fmu3):
    """fmpy's forward Euler at 1e-4 s on slip_steps, SecondOrder with Brush friction (the
    contact mass and four branches per element): equals CS within EULER_TOLERANCE
    (test_model_exchange: 3e-2, forward Euler's first-order error on the fastest
    transient) with the event count bounded as for CVode."""
    case = tme.slip_steps("SecondOrder", "Brush")
    compare3(case, "Euler", *fmu3)


# --------------------------------------------------------------------------- 4. FMU state

STATE_SEQ = f3.concatenate(f3.standstill_reversal(n_half=40), f3.piecewise_sequence(320, seed=7))
STATE_PARAMS = CS_PARAMS
ME_U = f3.me_inputs(120, seed=7)


@pytest.mark.parametrize("model", MODELS)
def test_cs_get_set_state_continues_bit_identically(new3, model):
    """Co-Simulation, Brush with low friction (sliding): a state taken after 150 steps,
    set back after 200 more steps and after disturbing all five inputs, gives the outputs
    of that time at once, the same time (the next step starts there) and then the same 200
    steps bit for bit (==); the state can be set again (it is not consumed)."""
    s = new3(model, STATE_PARAMS, friction="Brush")
    _, t = f3.drive3(s, 0.0, STATE_SEQ, 0, 150)
    y_saved = f3.outputs3(s)
    state = s.getFMUState()
    Y1, t1 = f3.drive3(s, t, STATE_SEQ, 150, 350)
    assert not np.array_equal(Y1[-1], y_saved), "the run did not change the outputs"
    s.setFloat64(fc.IN_VRS, [3.0, -0.7, 0.9, -0.4, 1000.0])
    s.setFMUState(state)
    assert np.array_equal(f3.outputs3(s), y_saved)
    Y2, t2 = f3.drive3(s, t, STATE_SEQ, 150, 350)      # fmi3DoStep from the saved time
    assert t2 == t1
    assert np.array_equal(Y1, Y2), f"max |diff| {np.max(np.abs(Y1 - Y2)):.3e}"
    s.setFMUState(state)
    Y3, _ = f3.drive3(s, t, STATE_SEQ, 150, 350)
    assert np.array_equal(Y1, Y3)
    s.freeFMUState(state)
    assert not s.log.errors(), s.log.text()


@pytest.mark.parametrize("model", MODELS)
def test_me_get_set_state_continues_bit_identically(new3, model):
    """Model Exchange (fmi3_common.EulerME: forward Euler, input and state events), Brush
    with low friction: a state taken in Continuous-Time Mode after 40 segments (0.4 s), set
    back after 60 more, continues with the same outputs and continuous states bit for bit;
    the run has state events (stick/slide switches or lift-off)."""
    fmu = new3(model, STATE_PARAMS, friction="Brush", me=True)
    driver = f3.EulerME(fmu)
    _, t = driver.run(0.0, ME_U, 0, 40)
    state = fmu.getFMUState()
    Y1, t1 = driver.run(t, ME_U, 40, 100)
    events = driver.state_events
    fmu.setFMUState(state)
    Y2, t2 = f3.EulerME(fmu).run(t, ME_U, 40, 100)
    fmu.freeFMUState(state)
    print(f"\n{model}: {events} state events in 1 s of Euler ME")
    assert events > 0
    assert t2 == t1
    assert np.all(np.isfinite(Y1))
    assert np.array_equal(Y1, Y2), f"max |diff| {np.max(np.abs(Y1 - Y2)):.3e}"
    assert not fmu.log.errors(), fmu.log.text()


def test_serialized_state_size_roundtrip_and_restore_into_another_instance(new3):
    """fmi3SerializedFMUStateSize gives the length fmi3SerializeFMUState writes;
    deserialize -> serialize gives the same bytes; the state set into another, differently
    configured and initialised instance (RLT, other parameters) brings its model,
    parameters and inputs and continues bit-identically."""
    a = new3("RingBody", STATE_PARAMS, friction="Coulomb")
    _, t = f3.drive3(a, 0.0, STATE_SEQ, 0, 200)
    state = a.getFMUState()
    size = SIZE()
    assert a.fmi3SerializedFMUStateSize(a.component, state, ctypes.byref(size)) == f3.FMI3_OK
    blob = a.serializeFMUState(state)
    assert size.value == len(blob) > 0
    st2 = a.deserializeFMUState(blob)
    assert a.serializeFMUState(st2) == blob
    a.freeFMUState(st2)
    a.freeFMUState(state)
    inputs = a.getFloat64(fc.IN_VRS)
    Ya, _ = f3.drive3(a, t, STATE_SEQ, 200, 400)

    b = new3("RLT", {"sigmaY": 2.5, "Calpha": 1.0e5}, friction="Unlimited")
    f3.drive3(b, 0.0, STATE_SEQ, 0, 37)
    sb = b.deserializeFMUState(blob)
    b.setFMUState(sb)
    b.freeFMUState(sb)
    assert b.getInt64([fc.MODEL_VR, fc.FRICTION_VR]) == [fc.MODELS["RingBody"], fc.FRICTIONS["Coulomb"]]
    assert b.getFloat64([fc.ALL_PARAMETER_VR[k] for k in STATE_PARAMS]) == list(STATE_PARAMS.values())
    assert b.getFloat64(fc.IN_VRS) == inputs
    Yb, _ = f3.drive3(b, t, STATE_SEQ, 200, 400)
    assert np.array_equal(Ya, Yb), f"max |diff| {np.max(np.abs(Ya - Yb)):.3e}"


def test_bad_serialized_states_are_refused(new3):
    """Truncated, bit-flipped, all-zero and extended blobs: fmi3DeserializeFMUState returns
    fmi3Error with a message; the instance is unchanged (it steps on like its twin) and the
    good blob is still accepted."""
    log = f3.LogCapture3()
    s = new3("DDT", STATE_PARAMS, log=log)
    twin = new3("DDT", STATE_PARAMS)
    _, t = f3.drive3(s, 0.0, STATE_SEQ, 0, 100)
    f3.drive3(twin, 0.0, STATE_SEQ, 0, 100)
    state = s.getFMUState()
    blob = s.serializeFMUState(state)
    s.freeFMUState(state)
    n = len(blob)
    bad = {"empty": b"", "truncated by 1": blob[:-1], "half": blob[: n // 2], "zeros": bytes(n),
           "one extra byte": blob + b"\x00", "doubled": blob + blob}
    for i in (0, 8, n // 2, n - 1):
        flipped = bytearray(blob)
        flipped[i] ^= 0x10
        bad[f"byte {i} flipped"] = bytes(flipped)
    for what, data in bad.items():
        log.clear()
        status, _ = fc.status_of(s.deserializeFMUState, data)
        assert status == f3.FMI3_ERROR, f"{what}: fmi3DeserializeFMUState returned {status}"
        assert log.errors(), f"{what}: no error message"
    assert np.array_equal(f3.outputs3(s), f3.outputs3(twin))
    Y, _ = f3.drive3(s, t, STATE_SEQ, 100, 140)
    Yt, _ = f3.drive3(twin, t, STATE_SEQ, 100, 140)
    assert np.array_equal(Y, Yt)
    good = s.deserializeFMUState(blob)
    s.setFMUState(good)
    s.freeFMUState(good)
    Y2, _ = f3.drive3(s, t, STATE_SEQ, 100, 140)
    assert np.array_equal(Y2, Y)


@pytest.fixture(scope="module")
def cross_process(tmp_path_factory, fmu3):
    """fmi3_state_worker.py twice: one process saves, a second, fresh process restores."""
    return fc.run_state_worker(worker3.__file__, tmp_path_factory.mktemp("fmi3_xproc"))


@pytest.mark.parametrize("iface,model,law", worker3.cases())
def test_state_restored_in_another_process_continues_bit_identically(cross_process, fmu3, iface, model, law):
    """Co-Simulation (1000 steps) and Model Exchange (160 Euler segments of 10 ms, outputs
    and continuous states): the second process, from a never-initialised instance, gives
    exactly (==) what the first gave after serializing; it reads back the model, friction
    law, parameters and inputs of the first. With friction the limits acted (max |Fy|
    below 0.9 of the linear tire's)."""
    out = cross_process
    case = worker3.case_name(iface, model, law)
    Y_save = np.load(out / f"{case}.save.npy")
    Y_load = np.load(out / f"{case}.load.npy")
    assert np.all(np.isfinite(Y_save)) and np.any(Y_save[:, :9] != 0.0)
    assert np.array_equal(Y_save, Y_load), f"second process differs: max |diff| {np.max(np.abs(Y_save - Y_load)):.3e}"
    readback = json.loads((out / f"{case}.load.json").read_text())
    assert readback["model"] == fc.MODELS[model]
    assert readback["friction"] == fc.FRICTIONS[law]
    starts = fc.start_values(fmu3[0])
    expected = {k: starts[k] for k in fc.ALL_PARAMETER_VR} | worker3.params(law)
    assert readback["params"] == expected
    if law != "Unlimited":
        Y_linear = np.load(out / f"{worker3.case_name(iface, model, 'Unlimited')}.save.npy")
        assert np.max(np.abs(Y_save[:, FY])) < 0.9 * np.max(np.abs(Y_linear[:, FY]))


# --------------------------------------------------------------------------- 5. bad input

WARM = 60
AFTER = (WARM, WARM + 60)


def stepping_pair3(new3, log, model="DDT"):
    """(s, twin, t): two FMI 3.0 Co-Simulation instances with the same history; s logs to log."""
    s = new3(model, STATE_PARAMS, log=log)
    twin = new3(model, STATE_PARAMS)
    _, t = f3.drive3(s, 0.0, STATE_SEQ, 0, WARM)
    _, t2 = f3.drive3(twin, 0.0, STATE_SEQ, 0, WARM)
    assert t == t2
    return s, twin, t


def assert_unchanged3(s, twin, t, what):
    """Same inputs, parameters, selectors and outputs as the twin, and the same run after."""
    assert s.getFloat64(fc.IN_VRS) == twin.getFloat64(fc.IN_VRS), f"{what}: inputs changed"
    pv = list(fc.ALL_PARAMETER_VR.values())
    assert s.getFloat64(pv) == twin.getFloat64(pv), f"{what}: parameters changed"
    sel = [fc.MODEL_VR, fc.FRICTION_VR]
    assert s.getInt64(sel) == twin.getInt64(sel), f"{what}: selectors changed"
    assert np.array_equal(f3.outputs3(s), f3.outputs3(twin)), f"{what}: outputs changed"
    Y, _ = f3.drive3(s, t, STATE_SEQ, *AFTER)
    Yt, _ = f3.drive3(twin, t, STATE_SEQ, *AFTER)
    assert np.array_equal(Y, Yt), f"{what}: the run after the bad call differs"


BAD_INPUTS = ([(n, v) for n in fc.INPUTS for v in (math.nan, math.inf, -math.inf)]
              + [(n, v) for n in ("vx", "vy", "steerRate", "vsx") for v in (1000.5, -2000.0)])


@pytest.mark.parametrize("name,value", BAD_INPUTS, ids=[f"{n}={v}" for n, v in BAD_INPUTS])
def test_bad_input_is_refused_and_changes_nothing(new3, name, value):
    """fmi3SetFloat64 of a non-finite input, or of vx, vy, steerRate, vsx outside their
    declared [-1000, 1000]: fmi3Error, an error message naming the input and the value;
    the instance is as its twin. The same value among good ones (all five inputs in one
    call) is refused as a whole."""
    log = f3.LogCapture3()
    s, twin, t = stepping_pair3(new3, log)
    log.clear()
    status, _ = fc.status_of(s.setFloat64, [fc.INPUT_VR[name]], [value])
    assert_error_logged(log, status, [name], value, f"fmi3SetFloat64 {name} = {value}")
    good = [2.0, 0.05, -0.1, 0.02, 45000.0]
    good[fc.INPUTS.index(name)] = value
    log.clear()
    status, _ = fc.status_of(s.setFloat64, fc.IN_VRS, good)
    assert_error_logged(log, status, [name], value, f"fmi3SetFloat64 of all inputs with {name} = {value}")
    assert_unchanged3(s, twin, t, f"{name} = {value}")


@pytest.mark.parametrize("vr", [6, 10, 20, 99, 126, 999, 2**31, 2**32 - 1])
def test_unknown_value_reference_is_refused(new3, vr):
    """fmi3Get/SetFloat64 and fmi3Get/SetInt64 on a value reference the FMU does not
    have: fmi3Error naming it; nothing changes."""
    log = f3.LogCapture3()
    s, twin, t = stepping_pair3(new3, log)
    for call, args in [(s.setFloat64, ([vr], [1.0])), (s.getFloat64, ([vr],)),
                       (s.setInt64, ([vr], [1])), (s.getInt64, ([vr],))]:
        log.clear()
        status, _ = fc.status_of(call, *args)
        assert_error_logged(log, status, [str(vr)], None, f"{call.__name__} vr {vr}")
    assert_unchanged3(s, twin, t, f"unknown vr {vr}")


def test_wrong_types_causalities_and_late_parameters_are_refused(new3):
    """Each refused with fmi3Error and a message naming the variable: fmi3GetInt32 and
    fmi3SetInt32 on tireModel (an Enumeration: Int64 only), fmi3GetFloat64 and
    fmi3SetFloat64 on tireModel, fmi3GetInt64 on Calpha (Float64), fmi3SetFloat64 on the
    output Fy, on the independent variable time, a fixed parameter (sigmaY) and a selector
    (tireModel, fmi3SetInt64) changed after initialisation, a selector out of its range.
    Nothing changes."""
    log = f3.LogCapture3()
    s, twin, t = stepping_pair3(new3, log, "SecondOrder")
    get_i32 = f3.c_function(s, "fmi3GetInt32", ctypes.c_int, VOID, P(U32), SIZE, P(ctypes.c_int32), SIZE)
    set_i32 = f3.c_function(s, "fmi3SetInt32", ctypes.c_int, VOID, P(U32), SIZE, P(ctypes.c_int32), SIZE)
    vr_model = (U32 * 1)(fc.MODEL_VR)
    i32 = (ctypes.c_int32 * 1)(2)
    cases = [
        ("fmi3GetInt32 tireModel", lambda: (get_i32(s.component, vr_model, 1, i32, 1), None), ["tireModel"], None),
        ("fmi3SetInt32 tireModel", lambda: (set_i32(s.component, vr_model, 1, i32, 1), None), ["tireModel"], None),
        ("fmi3GetFloat64 tireModel", lambda: fc.status_of(s.getFloat64, [fc.MODEL_VR]), ["tireModel"], None),
        ("fmi3SetFloat64 tireModel", lambda: fc.status_of(s.setFloat64, [fc.MODEL_VR], [3.0]), ["tireModel"], None),
        ("fmi3GetInt64 Calpha", lambda: fc.status_of(s.getInt64, [fc.PARAMETER_VR["Calpha"]]), ["Calpha"], None),
        ("fmi3SetFloat64 Fy", lambda: fc.status_of(s.setFloat64, [fc.OUTPUT_VR["Fy"]], [1.0]), ["Fy"], None),
        ("fmi3SetFloat64 time", lambda: fc.status_of(s.setFloat64, [f3.TIME_VR], [1.0]), ["time"], None),
        ("sigmaY after initialisation", lambda: fc.status_of(s.setFloat64, [fc.PARAMETER_VR["sigmaY"]], [2.0]),
         ["sigmaY"], 2.0),
        ("tireModel after initialisation", lambda: fc.status_of(s.setInt64, [fc.MODEL_VR], [1]), ["tireModel"], 1.0),
        ("friction out of range", lambda: fc.status_of(s.setInt64, [fc.FRICTION_VR], [7]), ["friction"], 7.0),
    ]
    for what, call, names, value in cases:
        log.clear()
        status, _ = call()
        assert_error_logged(log, status, names, value, what)
    assert_unchanged3(s, twin, t, "wrong types")


def test_selectors_are_int64(new3, fmu3):
    """fmi3GetInt64 reads the selectors' start values (tireModel DDT = 2, friction Brush =
    3) in Initialization Mode; fmi3SetInt64 sets them (RingBody, Coulomb) and they read
    back; after initialisation setting the value in use is accepted, and the instance runs
    exactly like one configured through initialise3. (Reads are made in Initialization
    Mode: whether fmi3Get* is allowed in Instantiated differs between versions of the
    Reference FMUs, and the FMU refuses it, as its FMI 2.0 interface does.)"""
    log = f3.LogCapture3()
    starts = {v.name: v.start for v in fmu3[0].modelVariables}
    fresh = new3(log=log, init=False)
    fresh.enterInitializationMode(startTime=0.0)
    assert fresh.getInt64([fc.MODEL_VR, fc.FRICTION_VR]) == [int(starts["tireModel"]), int(starts["friction"])] == [2, 3]
    s = new3(log=log, init=False)
    s.setInt64([fc.MODEL_VR, fc.FRICTION_VR], [fc.MODELS["RingBody"], fc.FRICTIONS["Coulomb"]])
    s.setFloat64([fc.ALL_PARAMETER_VR[k] for k in STATE_PARAMS], list(STATE_PARAMS.values()))
    s.enterInitializationMode(startTime=0.0)
    assert s.getInt64([fc.MODEL_VR, fc.FRICTION_VR]) == [4, 2]
    s.exitInitializationMode()
    s.setInt64([fc.MODEL_VR, fc.FRICTION_VR], [4, 2])           # the values in use: accepted
    assert not log.errors(), log.text()
    Y, _ = f3.drive3(s, 0.0, STATE_SEQ, 0, 80)
    Yf, _ = f3.drive3(new3("RingBody", STATE_PARAMS, friction="Coulomb"), 0.0, STATE_SEQ, 0, 80)
    assert np.array_equal(Y, Yf)


def test_call_sequence_is_enforced(new3):
    """fmi3DoStep before initialisation (instantiated, and in Initialization Mode), a step
    from the wrong time, a step <= 0, a NaN step: fmi3Error with a message; after
    initialisation the instance steps exactly like a fresh one."""
    log = f3.LogCapture3()
    s = new3(log=log, init=False)
    status, _ = fc.status_of(s.doStep, 0.0, 0.01)
    assert_error_logged(log, status, [], None, "fmi3DoStep before fmi3EnterInitializationMode")
    s.enterInitializationMode(startTime=0.0)
    log.clear()
    status, _ = fc.status_of(s.doStep, 0.0, 0.01)
    assert_error_logged(log, status, [], None, "fmi3DoStep in Initialization Mode")
    s.exitInitializationMode()
    _, t = f3.drive3(s, 0.0, STATE_SEQ, 0, 20)
    for what, args in [("wrong time", (t + 0.5, 0.01)), ("zero step", (t, 0.0)),
                       ("negative step", (t, -0.01)), ("NaN step", (t, math.nan))]:
        log.clear()
        status, _ = fc.status_of(s.doStep, *args)
        assert_error_logged(log, status, [], None, what)
    Y, _ = f3.drive3(s, t, STATE_SEQ, 20, 60)
    fresh = new3()
    _, tf = f3.drive3(fresh, 0.0, STATE_SEQ, 0, 20)
    Yf, _ = f3.drive3(fresh, tf, STATE_SEQ, 20, 60)
    assert np.array_equal(Y, Yf)


def test_interface_functions_are_refused_on_the_other_interface(new3):
    """fmi3DoStep on a Model Exchange instance, and fmi3GetContinuousStateDerivatives and
    fmi3EnterEventMode (no event mode in Co-Simulation) on a Co-Simulation instance:
    fmi3Error (3) with a message naming the function."""
    log_me, log_cs = f3.LogCapture3(), f3.LogCapture3()
    me = new3(log=log_me, me=True)
    cs = new3(log=log_cs)
    do_step = f3.c_function(me, "fmi3DoStep", ctypes.c_int, VOID, ctypes.c_double, ctypes.c_double,
                            ctypes.c_bool, P(ctypes.c_bool), P(ctypes.c_bool), P(ctypes.c_bool),
                            P(ctypes.c_double))
    flags = [ctypes.c_bool() for _ in range(3)]
    last = ctypes.c_double()
    log_me.clear()
    assert do_step(me.component, 0.0, 0.01, True, *[ctypes.byref(b) for b in flags], ctypes.byref(last)) == 3
    assert any("fmi3DoStep" in m for m in log_me.errors()), log_me.text()
    derivatives = f3.c_function(cs, "fmi3GetContinuousStateDerivatives", ctypes.c_int, VOID, P(ctypes.c_double), SIZE)
    dx = (ctypes.c_double * f3.N_STATES)()
    log_cs.clear()
    assert derivatives(cs.component, dx, f3.N_STATES) == 3
    assert any("fmi3GetContinuousStateDerivatives" in m for m in log_cs.errors()), log_cs.text()
    enter_event_mode = f3.c_function(cs, "fmi3EnterEventMode", ctypes.c_int, VOID)
    log_cs.clear()
    assert enter_event_mode(cs.component) == 3
    assert any("fmi3EnterEventMode" in m for m in log_cs.errors()), log_cs.text()


def test_model_exchange_bad_states_and_time_are_refused(new3):
    """Model Exchange: fmi3SetContinuousStates with a NaN or infinite entry, or with 17
    values, and fmi3SetTime with NaN: fmi3Error with a message naming the function; the
    states, derivatives and time stay as they were."""
    log = f3.LogCapture3()
    fmu = new3("RingBody", log=log, me=True, inputs=dict(vx=3.0, vy=0.1))
    fmu.setTime(0.5)
    x = (ctypes.c_double * f3.N_STATES)()
    fmu.getContinuousStates(x, f3.N_STATES)
    x[0], x[4] = 1e-4, -2e-4
    fmu.setContinuousStates(x, f3.N_STATES)
    before = (fmu.getFloat64(f3.STATE_VRS), fmu.getFloat64(f3.DERIVATIVE_VRS), fmu.getFloat64([f3.TIME_VR]))
    for what, k, value in [("NaN", 3, math.nan), ("inf", 17, math.inf)]:
        bad = (ctypes.c_double * f3.N_STATES)(*x)
        bad[k] = value
        log.clear()
        status, _ = fc.status_of(fmu.setContinuousStates, bad, f3.N_STATES)
        assert_error_logged(log, status, ["fmi3SetContinuousStates"], None, f"state {k} = {what}")
    for what, call, args, name in [("17 states", fmu.setContinuousStates, (x, 17), "fmi3SetContinuousStates"),
                                   ("NaN time", fmu.setTime, (math.nan,), "fmi3SetTime")]:
        log.clear()
        status, _ = fc.status_of(call, *args)
        assert_error_logged(log, status, [name], None, what)
    after = (fmu.getFloat64(f3.STATE_VRS), fmu.getFloat64(f3.DERIVATIVE_VRS), fmu.getFloat64([f3.TIME_VR]))
    assert after == before


def _loaded_library(fmu3, name):
    """An FMU3Slave whose library is loaded but that is not instantiated."""
    from fmpy.fmi3 import FMU3Slave

    md, unzipdir = fmu3
    return FMU3Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier="TireLag", instanceName=name)


def test_refused_instantiations_return_null(fmu3):
    """Raw fmi3Instantiate* calls (fmpy's instantiate raises on NULL): Co-Simulation with
    eventModeUsed = true, fmi3InstantiateScheduledExecution, and Co-Simulation and Model
    Exchange with a wrong instantiationToken or an empty instance name (docs/specification.md 7) return
    NULL, each with an error message
    through the logMessage callback (eventModeUsed: a message that names it, or says
    "event mode"). The same
    call with eventModeUsed = false and earlyReturnAllowed = true returns an instance."""
    from fmpy.fmi3 import (fmi3ClockUpdateCallback, fmi3IntermediateUpdateCallback,
                           fmi3LockPreemptionCallback, fmi3LogMessageCallback,
                           fmi3UnlockPreemptionCallback)

    lib = _loaded_library(fmu3, "null")
    md, unzipdir = fmu3
    resources = f"{unzipdir}/resources/".encode()
    token = md.guid.encode()
    try:
        cs = f3.c_function(lib, "fmi3InstantiateCoSimulation", VOID, ctypes.c_char_p, ctypes.c_char_p,
                           ctypes.c_char_p, ctypes.c_bool, ctypes.c_bool, ctypes.c_bool, ctypes.c_bool,
                           P(U32), SIZE, VOID, fmi3LogMessageCallback, fmi3IntermediateUpdateCallback)
        me = f3.c_function(lib, "fmi3InstantiateModelExchange", VOID, ctypes.c_char_p, ctypes.c_char_p,
                           ctypes.c_char_p, ctypes.c_bool, ctypes.c_bool, VOID, fmi3LogMessageCallback)
        se = f3.c_function(lib, "fmi3InstantiateScheduledExecution", VOID, ctypes.c_char_p, ctypes.c_char_p,
                           ctypes.c_char_p, ctypes.c_bool, ctypes.c_bool, VOID, fmi3LogMessageCallback,
                           fmi3ClockUpdateCallback, fmi3LockPreemptionCallback, fmi3UnlockPreemptionCallback)
        free = f3.c_function(lib, "fmi3FreeInstance", None, VOID)
        no_update = fmi3IntermediateUpdateCallback()

        def noop(*args):
            pass

        clock, lock, unlock = fmi3ClockUpdateCallback(noop), fmi3LockPreemptionCallback(noop), \
            fmi3UnlockPreemptionCallback(noop)
        calls = {
            "CS eventModeUsed": (lambda log: cs(b"em", token, resources, False, False, True, False, None, 0, None,
                                                log.c_callback, no_update), ["eventModeUsed", "event mode"]),
            "ScheduledExecution": (lambda log: se(b"se", token, resources, False, False, None, log.c_callback,
                                                  clock, lock, unlock), []),
            "CS wrong token": (lambda log: cs(b"tok", b"{00000000-0000-0000-0000-000000000000}", resources,
                                              False, False, False, False, None, 0, None, log.c_callback,
                                              no_update), []),
            "ME wrong token": (lambda log: me(b"tok", b"{00000000-0000-0000-0000-000000000000}", resources,
                                              False, False, None, log.c_callback), []),
            "CS empty instance name": (lambda log: cs(b"", token, resources, False, False, False, False, None, 0,
                                                      None, log.c_callback, no_update), ["instanceName"]),
            "ME empty instance name": (lambda log: me(b"", token, resources, False, False, None, log.c_callback),
                                       ["instanceName"]),
        }
        for what, (call, names) in calls.items():
            log = f3.LogCapture3()
            instance = call(log)
            if instance:
                free(instance)
            assert not instance, f"{what}: an instance was returned, expected NULL"
            assert log.errors(), f"{what}: NULL without an error message"
            # names: alternatives, one of which the message must contain (none: any message)
            assert not names or any(n.lower() in m.lower() for n in names for m in log.errors()), \
                (what, log.text())
        log = f3.LogCapture3()
        instance = cs(b"early", token, resources, False, False, False, True, None, 0, None, log.c_callback, no_update)
        assert instance, f"earlyReturnAllowed = true refused:\n{log.text()}"
        free(instance)
        assert not log.errors(), log.text()
    finally:
        lib.freeLibrary()


def _unsupported_calls():
    """(function, C argument types, arguments after the instance) of every unsupported
    FMI 3.0 function, with one value reference (vy, vr 2, or the clock/partition 2)."""
    d = ctypes.c_double
    vr = (U32 * 1)(fc.INPUT_VR["vy"])
    n1 = SIZE(1)
    calls = [
        ("fmi3EnterConfigurationMode", [], []),
        ("fmi3ExitConfigurationMode", [], []),
        ("fmi3EvaluateDiscreteStates", [], []),
        ("fmi3EnterStepMode", [], []),
        ("fmi3ActivateModelPartition", [U32, d], [2, 0.0]),
        ("fmi3GetAdjointDerivative", [P(U32), SIZE, P(U32), SIZE, P(d), SIZE, P(d), SIZE],
         [(U32 * 1)(fc.OUTPUT_VR["Fy"]), 1, vr, 1, (d * 1)(1.0), 1, (d * 1)(), 1]),
        ("fmi3GetNumberOfVariableDependencies", [U32, P(SIZE)], [fc.OUTPUT_VR["Fy"], ctypes.byref(SIZE())]),
        ("fmi3GetVariableDependencies", [U32, P(SIZE), P(U32), P(SIZE), P(ctypes.c_int), SIZE],
         [fc.OUTPUT_VR["Fy"], (SIZE * 1)(), (U32 * 1)(), (SIZE * 1)(), (ctypes.c_int * 1)(), 1]),
        ("fmi3GetClock", [P(U32), SIZE, P(ctypes.c_bool)], [vr, 1, (ctypes.c_bool * 1)()]),
        ("fmi3SetClock", [P(U32), SIZE, P(ctypes.c_bool)], [vr, 1, (ctypes.c_bool * 1)(True)]),
        ("fmi3GetIntervalDecimal", [P(U32), SIZE, P(d), P(ctypes.c_int)], [vr, 1, (d * 1)(), (ctypes.c_int * 1)()]),
        ("fmi3GetIntervalFraction", [P(U32), SIZE, P(ctypes.c_uint64), P(ctypes.c_uint64), P(ctypes.c_int)],
         [vr, 1, (ctypes.c_uint64 * 1)(), (ctypes.c_uint64 * 1)(), (ctypes.c_int * 1)()]),
        ("fmi3GetShiftDecimal", [P(U32), SIZE, P(d)], [vr, 1, (d * 1)()]),
        ("fmi3GetShiftFraction", [P(U32), SIZE, P(ctypes.c_uint64), P(ctypes.c_uint64)],
         [vr, 1, (ctypes.c_uint64 * 1)(), (ctypes.c_uint64 * 1)()]),
        ("fmi3SetIntervalDecimal", [P(U32), SIZE, P(d)], [vr, 1, (d * 1)(0.1)]),
        ("fmi3SetIntervalFraction", [P(U32), SIZE, P(ctypes.c_uint64), P(ctypes.c_uint64)],
         [vr, 1, (ctypes.c_uint64 * 1)(1), (ctypes.c_uint64 * 1)(10)]),
        ("fmi3SetShiftDecimal", [P(U32), SIZE, P(d)], [vr, 1, (d * 1)(0.1)]),
        ("fmi3SetShiftFraction", [P(U32), SIZE, P(ctypes.c_uint64), P(ctypes.c_uint64)],
         [vr, 1, (ctypes.c_uint64 * 1)(1), (ctypes.c_uint64 * 1)(10)]),
    ]
    for type_name, ctype in VALUE_TYPES:
        for op in ("Get", "Set"):
            calls.append((f"fmi3{op}{type_name}", [P(U32), SIZE, P(ctype), SIZE], [vr, n1, (ctype * 1)(), n1]))
    byte_p = P(ctypes.c_uint8)
    data = (ctypes.c_uint8 * 4)(1, 2, 3, 4)
    calls.append(("fmi3GetBinary", [P(U32), SIZE, P(SIZE), P(byte_p), SIZE], [vr, 1, (SIZE * 1)(), (byte_p * 1)(), 1]))
    calls.append(("fmi3SetBinary", [P(U32), SIZE, P(SIZE), P(byte_p), SIZE],
                  [vr, 1, (SIZE * 1)(4), (byte_p * 1)(ctypes.cast(data, byte_p)), 1]))
    return calls


# FMI 3.0 value types the FMU has no variable of (Int64 serves only the two selectors)
VALUE_TYPES = [("Float32", ctypes.c_float), ("Int8", ctypes.c_int8), ("UInt8", ctypes.c_uint8),
               ("Int16", ctypes.c_int16), ("UInt16", ctypes.c_uint16), ("Int32", ctypes.c_int32),
               ("UInt32", ctypes.c_uint32), ("UInt64", ctypes.c_uint64), ("Boolean", ctypes.c_bool)]
UNSUPPORTED = [name for name, _, _ in _unsupported_calls()]


@pytest.mark.parametrize("k", range(len(UNSUPPORTED)), ids=UNSUPPORTED)
def test_unsupported_function_is_an_error_that_names_itself(new3, k):
    """Called raw (explicit argument types) on an initialised Co-Simulation instance after
    60 steps: configuration mode, clocks, intervals and shifts, fmi3EvaluateDiscreteStates,
    fmi3ActivateModelPartition, fmi3GetAdjointDerivative, the variable-dependency
    functions, fmi3EnterStepMode, and Get/Set of every type the FMU has no variable of (one
    value reference) return fmi3Error (3) with an error message that names the function;
    the instance is unchanged and steps on like its twin."""
    log = f3.LogCapture3()
    s, twin, t = stepping_pair3(new3, log)
    name, argtypes, args = _unsupported_calls()[k]
    function = f3.c_function(s, name, ctypes.c_int, VOID, *argtypes)
    log.clear()
    status = function(s.component, *args)
    assert status == f3.FMI3_ERROR, f"{name}: status {status}, expected fmi3Error (3)\n{log.text()}"
    assert any(name in m for m in log.errors()), f"{name}: no error message naming it:\n{log.text()}"
    assert_unchanged3(s, twin, t, name)


def test_get_set_of_unused_types_with_no_value_references_is_ok(new3):
    """The other side of the rule for unused types: Get/Set of a type without variables
    and an empty value-reference list is fmi3OK, without an error message."""
    log = f3.LogCapture3()
    s = new3(log=log)
    vr = (U32 * 1)()
    for type_name, ctype in VALUE_TYPES:
        for op in ("Get", "Set"):
            name = f"fmi3{op}{type_name}"
            function = f3.c_function(s, name, ctypes.c_int, VOID, P(U32), SIZE, P(ctype), SIZE)
            assert function(s.component, vr, 0, (ctype * 1)(), 0) == f3.FMI3_OK, f"{name} with 0 value references"
    assert not log.errors(), log.text()


def test_directional_and_output_derivatives_equal_fmi2(new2, new3):
    """docs/specification.md 7c (the same derivatives): after the same 150 steps (sliding, Brush),
    fmi3GetDirectionalDerivative of the nine outputs with respect to each input and
    fmi3GetOutputDerivatives (order 1) equal the FMI 2.0 FMU's
    (fmi2GetDirectionalDerivative, fmi2GetRealOutputDerivatives without input
    derivatives) within 1e-12 of the largest entry."""
    s2 = new2("DDT", CS_PARAMS, friction="Brush")
    s3 = new3("DDT", CS_PARAMS, friction="Brush")
    _, t = fc.drive(s2, 0.0, CS_SEQ, 0, 150)
    f3.drive3(s3, 0.0, CS_SEQ, 0, 150)
    J2 = np.array([s2.getDirectionalDerivative(fc.OUT_VRS, [vr], [1.0]) for vr in fc.IN_VRS])
    J3 = np.array([s3.getDirectionalDerivative(fc.OUT_VRS, [vr], [1.0]) for vr in fc.IN_VRS])
    assert np.any(J2 != 0.0)
    assert np.abs(J3 - J2).max() <= 1e-12 * np.abs(J2).max(), (J3, J2)
    d2 = np.array(s2.getRealOutputDerivatives(fc.OUT_VRS, [1] * 9))
    d3 = np.array(s3.getOutputDerivatives(fc.OUT_VRS, [1] * 9))
    assert np.any(d2 != 0.0)
    assert np.abs(d3 - d2).max() <= 1e-12 * np.abs(d2).max(), (d3, d2)


# --------------------------------------------------------------------------- 6. logging

def test_errors_arrive_through_log_message_with_category_log_status_error(new3):
    """A refused parameter (sigmaY = -0.25 before initialisation): one call of the
    logMessage callback, status fmi3Error, category logStatusError, a message that names
    the function (fmi3SetFloat64), the variable and the value; the value is kept."""
    log = f3.LogCapture3()
    s = new3(log=log, init=False)
    status, _ = fc.status_of(s.setFloat64, [fc.PARAMETER_VR["sigmaY"]], [-0.25])
    assert status == f3.FMI3_ERROR
    assert len(log.messages) == 1, log.text()
    st, category, message = log.messages[0]
    assert (st, category) == (f3.FMI3_ERROR, "logStatusError"), log.text()
    assert "fmi3SetFloat64" in message and "sigmaY" in message and "-0.25" in message, message
    assert "fmi2" not in message, message
    s.enterInitializationMode(startTime=0.0)
    assert s.getFloat64([fc.PARAMETER_VR["sigmaY"]]) == [1.0]


CATEGORY = "100% load %s %d"


def test_percent_arrives_once(new3):
    """fmi3SetDebugLogging with an unknown category "100% load %s %d": fmi3Error and one
    message that quotes the name as it is: each '%' once (FMI 3.0 does not format the
    message, so FMI 2.0's '%%' escape would show), no '%%', and the message arrives once."""
    log = f3.LogCapture3()
    s = new3(log=log, init=False)
    status, _ = fc.status_of(s.setDebugLogging, True, [CATEGORY])
    assert status == f3.FMI3_ERROR
    quoting = [m for (_, _, m) in log.messages if "100%" in m]
    assert len(quoting) == 1, log.text()
    assert CATEGORY in quoting[0], quoting[0]
    assert "%%" not in quoting[0], quoting[0]
    assert log.messages[0][:2] == (f3.FMI3_ERROR, "logStatusError"), log.text()


def test_set_debug_logging_log_all_traces_calls(new3):
    """Logging off at instantiation: calls leave no logAll message. After
    fmi3SetDebugLogging(true, [logAll]), every call is traced with status fmi3OK and
    category logAll, named by its FMI 3.0 function and carrying its arguments in the FMI
    2.0 trace's format (test_logging: "fmi3SetFloat64(vr = [1, 2], value = [12.5, -0.25])",
    the step's time and size, the value a get returned). After
    fmi3SetDebugLogging(false, []) the trace stops."""
    log = f3.LogCapture3()
    s = new3(log=log, init=False)
    s.enterInitializationMode(startTime=0.5)
    s.exitInitializationMode()
    s.doStep(0.5, 0.001)
    assert not [m for m in log.messages if m[1] == "logAll"], log.text()
    s.setDebugLogging(True, ["logAll"])
    log.clear()
    s.setFloat64([fc.INPUT_VR["vx"], fc.INPUT_VR["vy"]], [12.5, -0.25])
    s.doStep(0.501, 0.002)
    fy = s.getFloat64([fc.OUTPUT_VR["Fy"]])[0]
    traced = [(st, m) for (st, c, m) in log.messages if c == "logAll"]
    text = "\n".join(m for _, m in traced)
    assert traced and all(st == f3.FMI3_OK for st, _ in traced), log.text()

    def line(prefix):
        found = [m for _, m in traced if m.startswith(prefix)]
        assert found, f"no logAll message starting {prefix!r}; got:\n{text}"
        return found

    vx, vy, fy_vr = fc.INPUT_VR["vx"], fc.INPUT_VR["vy"], fc.OUTPUT_VR["Fy"]
    assert any(f"vr = [{vx}, {vy}]" in m and "value = [12.5, -0.25]" in m for m in line("fmi3SetFloat64("))
    assert any("currentCommunicationPoint = 0.501" in m and "communicationStepSize = 0.002" in m
               for m in line("fmi3DoStep("))
    assert any(f"vr = [{fy_vr}]" in m and f"value -> [{fy!r}]" in m for m in line("fmi3GetFloat64(")), text
    s.setDebugLogging(False, [])
    log.clear()
    s.doStep(0.503, 0.001)
    assert not [m for m in log.messages if m[1] == "logAll"], log.text()


def test_logging_on_at_instantiation_traces_calls(fmu3):
    """loggingOn = true at fmi3InstantiateCoSimulation: the calls are traced (logAll)."""
    log = f3.LogCapture3()
    s = f3.new_slave3(*fmu3, name="trace", log=log, logging_on=True)
    try:
        f3.initialise3(s, "RLT")
        s.doStep(0.0, 0.01)
    finally:
        f3.close3(s)
    traced = [m for (_, c, m) in log.messages if c == "logAll"]
    assert any(m.startswith("fmi3EnterInitializationMode") for m in traced), log.text()
    assert any(m.startswith("fmi3DoStep") for m in traced), log.text()
