"""FMU state: get/set/free, serialize/deserialize in and across processes, corrupt
states, and fmi2Reset (docs/specification.md 7 and 8).

The serialized state holds parameters, model, inputs, input rates, states, time and the
phase, so a restored instance must continue bit-identically (==, not approximately).
"""

from __future__ import annotations

import ctypes
import json

import numpy as np
import pytest

import fmi4_common as fc
import fmi4_state_worker as worker

MODELS = list(fc.MODELS)


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    return fc.module_fmu(tmp_path_factory, "fmi4_state")


@pytest.fixture
def slaves(fmu):
    with fc.slave_factory(*fmu, "s") as new:
        yield new


SEQ = fc.input_sequence(600, seed=7)


# --------------------------------------------------------------------------- in-process

@pytest.mark.parametrize("model", MODELS)
def test_get_set_state_continues_bit_identically(slaves, model):
    s = slaves(model, fc.STATE_PARAMS)
    _, t = fc.drive(s, 0.0, SEQ, 0, 150)
    y_saved = fc.outputs(s)
    state = s.getFMUstate()
    Y1, t1 = fc.drive(s, t, SEQ, 150, 350)            # 200 steps
    assert not np.array_equal(Y1[-1], y_saved), "the run did not change the outputs"
    # disturb inputs and input rates too: the state must bring them back
    s.setReal(fc.IN_VRS, [3.0, -0.7, 0.9, -0.4, 1000.0])
    s.setRealInputDerivatives(fc.DRIVING_VRS, [1, 1, 1], [5.0, -5.0, 5.0])
    s.setFMUstate(state)
    assert np.array_equal(fc.outputs(s), y_saved)
    Y2, t2 = fc.drive(s, t, SEQ, 150, 350)             # starts at the saved time
    assert t2 == t1
    assert np.array_equal(Y1, Y2), f"max |diff| {np.max(np.abs(Y1 - Y2)):.3e}"
    # the same state again (a state is reusable), then free it
    s.setFMUstate(state)
    Y3, _ = fc.drive(s, t, SEQ, 150, 350)
    assert np.array_equal(Y1, Y3)
    s.freeFMUstate(state)


@pytest.mark.parametrize("model", MODELS)
def test_state_is_restored_into_another_instance(slaves, model):
    """Serialize in one instance, deserialize into a differently configured one."""
    a = slaves(model, fc.STATE_PARAMS)
    _, t = fc.drive(a, 0.0, SEQ, 0, 200)
    sa = a.getFMUstate()
    blob = a.serializeFMUstate(sa)
    a.freeFMUstate(sa)
    Ya, _ = fc.drive(a, t, SEQ, 200, 400)

    other = "RLT" if model != "RLT" else "RingBody"
    b = slaves(other, {"sigmaY": 2.5, "Calpha": 1.0e5})
    fc.drive(b, 0.0, SEQ, 0, 37)
    sb = b.deSerializeFMUstate(blob)
    b.setFMUstate(sb)
    b.freeFMUstate(sb)
    assert b.getInteger([fc.MODEL_VR]) == [fc.MODELS[model]]
    assert b.getReal(list(fc.PARAMETER_VR.values())) == [fc.STATE_PARAMS[k] for k in fc.PARAMETER_VR]
    Yb, _ = fc.drive(b, t, SEQ, 200, 400)
    assert np.array_equal(Ya, Yb), f"max |diff| {np.max(np.abs(Ya - Yb)):.3e}"


def test_get_fmu_state_reuses_an_existing_state(slaves):
    """fmi2GetFMUstate with a non-NULL *FMUstate overwrites that state."""
    s = slaves("SecondOrder")
    _, t = fc.drive(s, 0.0, SEQ, 0, 50)
    state = s.getFMUstate()
    _, t = fc.drive(s, t, SEQ, 50, 100)
    y100 = fc.outputs(s)
    s.fmi2GetFMUstate(s.component, ctypes.byref(state))     # reuse: now holds step 100
    Yref, tref = fc.drive(s, t, SEQ, 100, 150)
    s.setFMUstate(state)
    assert np.array_equal(fc.outputs(s), y100)
    Y, _ = fc.drive(s, t, SEQ, 100, 150)
    assert np.array_equal(Y, Yref)
    s.freeFMUstate(state)


def test_several_states_are_independent(slaves):
    s = slaves("RingBody")
    states, ys, ts = [], [], []
    t = 0.0
    for k in range(4):
        _, t = fc.drive(s, t, SEQ, 50 * k, 50 * (k + 1))
        states.append(s.getFMUstate())
        ys.append(fc.outputs(s))
        ts.append(t)
    s.freeFMUstate(states[1])
    for k in (3, 0, 2):
        s.setFMUstate(states[k])
        assert np.array_equal(fc.outputs(s), ys[k])
        assert s.getRealStatus(2) == ts[k]   # fmi2LastSuccessfulTime
    for k in (0, 2, 3):
        s.freeFMUstate(states[k])


def test_serialized_state_roundtrip_and_size(slaves):
    s = slaves("DDT")
    fc.drive(s, 0.0, SEQ, 0, 20)
    st = s.getFMUstate()
    blob = s.serializeFMUstate(st)
    size = ctypes.c_size_t()
    s.fmi2SerializedFMUstateSize(s.component, st, ctypes.byref(size))
    assert size.value == len(blob) > 0
    st2 = s.deSerializeFMUstate(blob)
    assert s.serializeFMUstate(st2) == blob
    s.freeFMUstate(st)
    s.freeFMUstate(st2)


# --------------------------------------------------------------------------- cross-process

@pytest.fixture(scope="module")
def cross_process(tmp_path_factory):
    """Run the worker twice: one process saves, a second, fresh process restores."""
    return fc.run_state_worker(worker.__file__, tmp_path_factory.mktemp("fmi4_xproc"))


@pytest.mark.parametrize("model,law", fc.STATE_CASES)
def test_state_restored_in_another_process_continues_bit_identically(cross_process, slaves, model, law):
    """With friction the state holds every branch deflection and stick/slide flag."""
    out = cross_process
    case = f"{model}-{law}"
    Y_save = np.load(out / f"{case}.save.npy")
    Y_load = np.load(out / f"{case}.load.npy")
    assert Y_save.shape == (worker.CONTINUE, 9)
    assert np.all(np.isfinite(Y_save)) and np.any(Y_save != 0.0)
    diff = np.max(np.abs(Y_save - Y_load))
    assert np.array_equal(Y_save, Y_load), f"second process differs: max |diff| {diff:.3e}"
    readback = json.loads((out / f"{case}.load.json").read_text())
    assert readback["model"] == fc.MODELS[model]
    assert readback["friction"] == fc.FRICTIONS[law]
    assert readback["params"] == fc.STATE_PARAMS
    if law != "Unlimited":
        # The limits acted: the forces stayed below the linear model's.
        Y_linear = np.load(out / f"{model}-Unlimited.save.npy")
        assert np.max(np.abs(Y_save[:, 1])) < 0.9 * np.max(np.abs(Y_linear[:, 1]))

    # and a third place: this test process, into an initialised instance of another model
    t = float(json.loads((out / f"{case}.json").read_text())["t"])
    blob = (out / f"{case}.state").read_bytes()
    s = slaves("RLT" if model != "RLT" else "DDT")
    st = s.deSerializeFMUstate(blob)
    s.setFMUstate(st)
    s.freeFMUstate(st)
    seq = worker.sequence()
    Y_here, _ = fc.drive(s, t, seq, worker.WARMUP, worker.WARMUP + worker.CONTINUE)
    assert np.array_equal(Y_save, Y_here), f"this process differs: max |diff| {np.max(np.abs(Y_save - Y_here)):.3e}"


# --------------------------------------------------------------------------- bad states

def _reference_run(slaves):
    s = slaves("RingBody", fc.STATE_PARAMS)
    _, t = fc.drive(s, 0.0, SEQ, 0, 100)
    state = s.getFMUstate()
    blob = s.serializeFMUstate(state)
    s.freeFMUstate(state)
    y_now = fc.outputs(s)
    return s, t, blob, y_now


def _assert_refused(s, log, blob, what):
    log.clear()
    status, _ = fc.status_of(s.deSerializeFMUstate, blob)
    assert status == fc.FMI2_ERROR, f"{what}: fmi2DeSerializeFMUstate returned {status}, expected fmi2Error"
    assert log.errors(), f"{what}: no error message logged"


def test_corrupt_truncated_and_foreign_states_are_refused(slaves):
    log = fc.LogCapture()
    ref, t, blob, _ = _reference_run(slaves)
    Yref, _ = fc.drive(ref, t, SEQ, 100, 130)

    s = slaves("RingBody", fc.STATE_PARAMS, log=log)       # same history as ref
    _, t2 = fc.drive(s, 0.0, SEQ, 0, 100)
    assert t2 == t
    y_before = fc.outputs(s)

    n = len(blob)
    # truncated at every length
    for k in range(n):
        _assert_refused(s, log, blob[:k], f"truncated to {k} of {n} bytes")
    # one flipped bit in every byte
    for i in range(n):
        bad = bytearray(blob)
        bad[i] ^= 1 << (i % 8)
        _assert_refused(s, log, bytes(bad), f"bit {i % 8} of byte {i} flipped")
    # foreign data
    rng = np.random.default_rng(3)
    foreign = {
        "zeros": bytes(n),
        "random": rng.integers(0, 256, n, dtype=np.uint8).tobytes(),
        "zip header": b"PK\x03\x04" + bytes(n - 4),
        "text": (b"TireLag state " * (n // 14 + 1))[:n],
        "doubled": blob + blob,
        "one extra byte": blob + b"\x00",
    }
    for what, data in foreign.items():
        _assert_refused(s, log, data, what)

    # nothing changed: outputs equal, and the instance steps on exactly like the reference
    assert np.array_equal(fc.outputs(s), y_before)
    Y, _ = fc.drive(s, t, SEQ, 100, 130)
    assert np.array_equal(Y, Yref)
    # and the good state is still accepted afterwards
    st = s.deSerializeFMUstate(blob)
    s.setFMUstate(st)
    s.freeFMUstate(st)
    Y2, _ = fc.drive(s, t, SEQ, 100, 130)
    assert np.array_equal(Y2, Yref)


def test_state_from_a_different_fmu_version_or_guid_is_refused(slaves):
    """A serialized state names its FMU; a blob whose header claims another GUID is foreign.
    Whatever the FMU checks (GUID, version or checksum), it must refuse it."""
    log = fc.LogCapture()
    s0 = slaves("DDT")
    st = s0.getFMUstate()
    blob = s0.serializeFMUstate(st)
    s0.freeFMUstate(st)
    md = fc.read_md()
    guid = md.guid.encode()
    s = slaves("DDT", log=log)
    if guid in blob:
        other = bytearray(blob)
        i = blob.index(guid)
        other[i + 1: i + 2] = b"0" if blob[i + 1: i + 2] != b"0" else b"1"
        _assert_refused(s, log, bytes(other), "another GUID")
    other = bytearray(blob)
    other[8] ^= 0x7F   # the bytes right after the magic (a version field in most layouts)
    _assert_refused(s, log, bytes(other), "another format version")


# --------------------------------------------------------------------------- reset

def test_reset_restores_start_values_time_and_phase(slaves, fmu):
    md, _ = fmu
    starts = {v.valueReference: v.start for v in md.modelVariables}
    s = slaves(init=False)
    s.setupExperiment(startTime=0.0)
    s.setInteger([fc.MODEL_VR], [fc.MODELS["RingBody"]])
    s.setReal([fc.PARAMETER_VR[k] for k in fc.STATE_PARAMS], list(fc.STATE_PARAMS.values()))
    s.enterInitializationMode()
    s.exitInitializationMode()
    _, t = fc.drive(s, 0.0, SEQ, 0, 120)
    assert t > 0.5
    s.reset()

    # phase 'instantiated': fixed parameters may be set again, a step is not allowed
    status, _ = fc.status_of(s.doStep, 0.0, 0.01)
    assert status == fc.FMI2_ERROR, "doStep right after fmi2Reset must be refused (not initialised)"
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    assert s.getInteger([fc.MODEL_VR]) == [int(starts[fc.MODEL_VR])]
    assert s.getInteger([fc.FRICTION_VR]) == [int(starts[fc.FRICTION_VR])]
    params = s.getReal(list(fc.ALL_PARAMETER_VR.values()))
    assert params == [float(starts[vr]) for vr in fc.ALL_PARAMETER_VR.values()]
    inputs = s.getReal(fc.IN_VRS)
    assert inputs == [float(starts.get(vr) or 0.0) for vr in fc.IN_VRS]
    s.exitInitializationMode()
    assert s.getRealStatus(2) == 0.0           # fmi2LastSuccessfulTime
    # time is 0 again: a step from t = 0 is accepted, and the run equals a fresh instance
    y0 = fc.outputs(s)
    Y, _ = fc.drive(s, 0.0, SEQ, 0, 120)
    fresh = slaves("DDT")
    assert np.array_equal(fc.outputs(fresh), y0)
    Yf, _ = fc.drive(fresh, 0.0, SEQ, 0, 120)
    assert np.array_equal(Y, Yf)


def test_reset_then_other_configuration(slaves):
    """After fmi2Reset the instance is as good as new: a different model and parameters work
    and give the same outputs as a fresh instance configured that way."""
    s = slaves("DDT", {"sigmaY": 1.7})
    _, t = fc.drive(s, 0.0, SEQ, 0, 80)
    s.reset()
    fc.initialise(s, "SecondOrder", {"contactMass": 12.0, "sigmaTread": 0.2})
    Y, _ = fc.drive(s, 0.0, SEQ, 0, 80)
    fresh = slaves("SecondOrder", {"contactMass": 12.0, "sigmaTread": 0.2})
    Yf, _ = fc.drive(fresh, 0.0, SEQ, 0, 80)
    assert np.array_equal(Y, Yf)


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("phase", ["instantiated", "initializationMode"])
def test_state_taken_before_initialisation_roundtrips(slaves, model, phase):
    """A state may be taken in any phase after fmi2Instantiate. One taken before
    exitInitializationMode, with the model already chosen, must set back (directly and
    via serialize/deserialize) into the same instance."""
    log = fc.LogCapture()
    s = slaves(init=False, log=log)
    s.setupExperiment(startTime=0.0)
    s.setInteger([fc.MODEL_VR], [fc.MODELS[model]])
    if phase == "initializationMode":
        s.enterInitializationMode()
    st = s.getFMUstate()
    status, _ = fc.status_of(s.setFMUstate, st)
    assert status == fc.FMI2_OK, f"fmi2SetFMUstate of its own {phase} state: status {status}\n{log.text()}"
    blob = s.serializeFMUstate(st)
    status, st2 = fc.status_of(s.deSerializeFMUstate, blob)
    assert status == fc.FMI2_OK, f"fmi2DeSerializeFMUstate of its own {phase} state: status {status}\n{log.text()}"
    s.freeFMUstate(st)


@pytest.mark.parametrize("model", MODELS)
def test_state_saved_in_initialization_mode_restores_that_phase(slaves, model):
    """The phase is part of the state: a state taken in initialisation mode, set into an
    instance that is stepping, brings it back to initialisation mode (doStep refused,
    fixed parameters settable, exitInitializationMode then works)."""
    log = fc.LogCapture()
    s = slaves(init=False, log=log)
    s.setupExperiment(startTime=0.0)
    s.setInteger([fc.MODEL_VR], [fc.MODELS[model]])
    s.enterInitializationMode()
    st_init = s.getFMUstate()
    s.exitInitializationMode()
    fc.drive(s, 0.0, SEQ, 0, 20)
    status, _ = fc.status_of(s.setFMUstate, st_init)
    assert status == fc.FMI2_OK, f"fmi2SetFMUstate: status {status}\n{log.text()}"
    s.freeFMUstate(st_init)
    status, _ = fc.status_of(s.doStep, 0.0, 0.01)
    assert status == fc.FMI2_ERROR, "doStep must be refused in initialisation mode"
    s.setReal([fc.PARAMETER_VR["Calpha"]], [300000.0])     # allowed before exit
    s.exitInitializationMode()
    Y, _ = fc.drive(s, 0.0, SEQ, 0, 40)
    fresh = slaves(model, {"Calpha": 300000.0})
    Yf, _ = fc.drive(fresh, 0.0, SEQ, 0, 40)
    assert np.array_equal(Y, Yf)
