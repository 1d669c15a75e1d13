"""Helpers for the FMI 3.0 tests (test_fmi3.py and its worker, fmi3_state_worker.py).

The FMI 3.0 FMU is <repo>/target/fmu/fmi3/TireLag.fmu (docs/specification.md 7c): the same library as the
FMI 2.0 FMU, driven here through fmpy.fmi3 (FMU3Slave, FMU3Model). What the FMI 2.0
tests already define (value references, parameter sets, input sequences, the FMI 2.0
driver) is taken from fmi4_common; this module adds only what FMI 3.0 needs:

* LogCapture3: the FMI 3.0 logMessage callback (a plain function of instanceEnvironment,
  status, category, message; no variadic arguments, so no fmpy logger proxy is involved);
* new_slave3 / new_model3 / initialise3 / initialise_me3: instances, set up like
  fmi4_common.new_slave / initialise (selectors through fmi3SetInt64, parameters and
  inputs through fmi3SetFloat64);
* drive3: fmi4_common.drive for FMI 3.0 Co-Simulation (inputs held over each step: FMI 3.0
  has no input derivatives), checking the fmi3DoStep flags of every step;
* EulerME: a small deterministic Model Exchange master (forward Euler, input and state
  events in Event Mode) for the FMU-state tests, which need a reproducible run.
"""

from __future__ import annotations

import contextlib
import ctypes
from pathlib import Path

import numpy as np

import fmi4_common as fc
from fmi4_common import N_INDICATORS, N_STATES, STATE_NAMES  # noqa: F401  (also as f3.N_STATES, ...)

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
FMU3_PATH = REPO / "target" / "fmu" / "fmi3" / "TireLag.fmu"
BINARY3 = "binaries/x86_64-linux/TireLag.so"

FMI3_OK, FMI3_WARNING, FMI3_DISCARD, FMI3_ERROR = 0, 1, 2, 3

STATE_VRS = list(range(200, 206)) + list(range(210, 222))
DERIVATIVE_VRS = [vr + 100 for vr in STATE_VRS]
INDICATOR_NAMES = ([f"guardPlanar{i}" for i in range(1, 5)] + [f"guardYaw{i}" for i in range(1, 5)]
                   + ["guardLoad"])
INDICATOR_VRS = list(range(400, 409))
TIME_VR = 0
TIR_FILE_VR = 130


# --------------------------------------------------------------------------- logging

class LogCapture3(fc.MessageLog):
    """Records (status, category, message) of every fmi3LogMessageCallback call.

    Pass `log.callback` as fmpy's instantiate(logMessage=...) (fmpy wraps it in
    fmi3LogMessageCallback and keeps that alive with the instance), or `log.c_callback`
    to a raw fmi3Instantiate* call. The interface of fmi4_common.LogCapture (messages,
    clear, errors, text: fmi4_common.MessageLog), so test_bad_input.assert_error_logged
    works with both."""

    def __init__(self):
        from fmpy.fmi3 import fmi3LogMessageCallback

        super().__init__()
        self.c_callback = fmi3LogMessageCallback(self.callback)

    def callback(self, instance_environment, status, category, message):
        self.record(status, category, message)


# --------------------------------------------------------------------------- the FMU

def read_md3():
    from fmpy import read_model_description

    return read_model_description(str(FMU3_PATH))


def extract_fmu3(dest):
    from fmpy import extract

    return extract(str(FMU3_PATH), unzipdir=str(dest))


def new_slave3(md, unzipdir, name="tire3", log=None, logging_on=False, **instantiate_args):
    """An FMU3Slave that is only instantiated; its log is `slave.log` (a LogCapture3)."""
    from fmpy.fmi3 import FMU3Slave

    log = log if log is not None else LogCapture3()
    slave = FMU3Slave(guid=md.guid, unzipDirectory=unzipdir,
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    slave.instantiate(loggingOn=logging_on, logMessage=log.callback, **instantiate_args)
    slave.log = log
    return slave


def new_model3(md, unzipdir, name="me3", log=None, cls=None):
    """An FMU3Model (by default an FMU3CountingModel) that is only instantiated."""
    from fmpy.fmi3 import FMU3Model

    cls = cls or fc.counting_model_class(FMU3Model)
    log = log if log is not None else LogCapture3()
    fmu = cls(guid=md.guid, unzipDirectory=unzipdir,
              modelIdentifier=md.modelExchange.modelIdentifier, instanceName=name)
    fmu.instantiate(logMessage=log.callback)
    fmu.log = log
    return fmu


def configure3(fmu, model=None, params=None, friction=None):
    """Selectors (fmi3SetInt64) and parameters (fmi3SetFloat64), before initialisation."""
    if model is not None:
        fmu.setInt64([fc.MODEL_VR], [fc.MODELS[model]])
    if friction is not None:
        fmu.setInt64([fc.FRICTION_VR], [fc.FRICTIONS[friction]])
    if params:
        fmu.setFloat64([fc.ALL_PARAMETER_VR[k] for k in params], [float(v) for v in params.values()])


def initialise3(fmu, model="DDT", params=None, inputs=None, friction=None, start_time=0.0):
    """Co-Simulation: as fmi4_common.initialise (friction None: the FMU's default, Brush)."""
    configure3(fmu, model, params, friction)
    fmu.enterInitializationMode(startTime=start_time)
    fmu.exitInitializationMode()
    if inputs:
        fmu.setFloat64([fc.INPUT_VR[k] for k in inputs], [float(v) for v in inputs.values()])
    return fmu


def update_discrete_states(fmu):
    """fmi3UpdateDiscreteStates until no update is needed (at most 100 times)."""
    for _ in range(100):
        need, terminate, *_ = fmu.updateDiscreteStates()
        assert not terminate, "the FMU asked to terminate"
        if not need:
            return
    raise AssertionError("fmi3UpdateDiscreteStates did not settle in 100 iterations")


def initialise_me3(fmu, model="DDT", params=None, inputs=None, friction=None, start_time=0.0):
    """Model Exchange: configure, initialise, the initial event iteration (inputs set in
    Event Mode before it), then Continuous-Time Mode."""
    configure3(fmu, model, params, friction)
    fmu.enterInitializationMode(startTime=start_time)
    fmu.exitInitializationMode()
    if inputs:
        fmu.setFloat64([fc.INPUT_VR[k] for k in inputs], [float(v) for v in inputs.values()])
    update_discrete_states(fmu)
    fmu.enterContinuousTimeMode()
    return fmu


def close3(fmu):
    try:
        fmu.terminate()
    except Exception:
        pass
    fmu.freeInstance()


def outputs3(fmu):
    return np.array(fmu.getFloat64(fc.OUT_VRS))


@contextlib.contextmanager
def instance_factory3(md, unzipdir, prefix):
    """Yields new(model, params, inputs, log, init, friction, me) -> an FMU3Slave (me=False)
    or FMU3Model (me=True), initialised unless init=False; frees every one at the end."""
    made = []

    def new(model="DDT", params=None, inputs=None, log=None, init=True, friction=None, me=False):
        name = f"{prefix}{len(made)}"
        fmu = new_model3(md, unzipdir, name, log) if me else new_slave3(md, unzipdir, name, log)
        made.append(fmu)
        if init:
            (initialise_me3 if me else initialise3)(fmu, model, params, inputs, friction=friction)
        return fmu

    try:
        yield new
    finally:
        for fmu in made:
            close3(fmu)


def c_function(fmu, name, restype, *argtypes):
    """The library's function `name` with an explicit C signature, as a new ctypes function
    object (CDLL item access does not share fmpy's cached, annotated one)."""
    function = fmu.dll[name]
    function.argtypes = list(argtypes)
    function.restype = restype
    return function


# --------------------------------------------------------------------------- input sequences

def piecewise_sequence(n, seed):
    """fmi4_common.input_sequence without input rates: the inputs are held over each step
    (piecewise constant), which FMI 3.0 Co-Simulation does and the FMI 2.0 FMU does when
    no input derivatives are set."""
    seq = fc.input_sequence(n, seed)
    seq["rate_mask"] = np.zeros(n, bool)
    return seq


def standstill_reversal(n_half=80, h=0.01, vy=0.5, steer_rate=0.4, Fz=50000.0):
    """vx = 0: the hub pushed sideways (vy) and steered for n_half steps, then the same
    backwards (a reversal at standstill). By default 0.4 m and 0.32 rad each way: past
    twice the elastic travel of every Brush branch at the low friction used here
    (fmi4_common.STATE_FRICTION_PARAMS: Fmax_y/C_y = 5.5 cm, the last branch at 2.32
    times that), so the force swings from one limit to the other. No longitudinal slip:
    the lateral force alone reaches its limit."""
    U = np.array([[0.0, vy, steer_rate, 0.0, Fz]] * n_half + [[0.0, -vy, -steer_rate, 0.0, Fz]] * n_half)
    n = 2 * n_half
    return {"h": np.full(n, h), "U": U, "set_mask": np.ones(n, bool), "R": np.zeros((n, 3)),
            "rate_mask": np.zeros(n, bool)}


def concatenate(*seqs):
    return {k: np.concatenate([s[k] for s in seqs]) for k in seqs[0]}


# --------------------------------------------------------------------------- Co-Simulation driver

def drive3(slave, t, seq, start=0, stop=None):
    """fmi4_common.drive for an FMU3Slave: run seq[start:stop] from time t; returns
    (Y (m, 9), t_end). Every fmi3DoStep must return fmi3OK with eventHandlingNeeded,
    terminateSimulation and earlyReturn false and lastSuccessfulTime = t + h (the
    FMU has no event mode in Co-Simulation and never returns early)."""
    from fmpy.fmi3 import fmi3Boolean, fmi3Float64

    f = slave
    comp = f.component
    stop = len(seq["h"]) if stop is None else stop
    vr_in = (ctypes.c_uint32 * 5)(*fc.IN_VRS)
    vr_out = (ctypes.c_uint32 * 9)(*fc.OUT_VRS)
    val = (ctypes.c_double * 5)()
    out = (ctypes.c_double * 9)()
    event, terminate, early = fmi3Boolean(), fmi3Boolean(), fmi3Boolean()
    last = fmi3Float64()
    Y = np.empty((stop - start, 9))
    for i, k in enumerate(range(start, stop)):
        if seq["rate_mask"][k]:
            raise ValueError("FMI 3.0 has no input derivatives: use piecewise_sequence")
        if seq["set_mask"][k]:
            val[:] = [float(v) for v in seq["U"][k]]
            assert f.fmi3SetFloat64(comp, vr_in, 5, val, 5) == FMI3_OK
        h = float(seq["h"][k])
        assert f.fmi3DoStep(comp, t, h, True, ctypes.byref(event), ctypes.byref(terminate),
                            ctypes.byref(early), ctypes.byref(last)) == FMI3_OK
        flags = (event.value, terminate.value, early.value)
        assert flags == (False, False, False), f"step {k}: fmi3DoStep flags {flags}"
        assert last.value == t + h, f"step {k}: lastSuccessfulTime {last.value!r}, expected {t + h!r}"
        t += h
        assert f.fmi3GetFloat64(comp, vr_out, 9, out, 9) == FMI3_OK
        Y[i] = out[:]
    return Y, t


# --------------------------------------------------------------------------- Model Exchange driver

ME_SUBSTEP = 5e-4      # forward Euler step; below 2/lambda of the fastest mode used here
ME_SUBSTEPS = 20       # substeps per input segment (inputs held 10 ms)


class EulerME:
    """A deterministic FMI 3.0 Model Exchange master for the FMU-state tests: each input
    segment starts with an input event (fmi3EnterEventMode, the five inputs,
    fmi3UpdateDiscreteStates until done, fmi3EnterContinuousTimeMode), then `substeps`
    forward Euler steps of `h` (fmi3SetTime, fmi3SetContinuousStates,
    fmi3CompletedIntegratorStep), each followed by a state event (Event Mode, as above)
    where an event indicator changed sign. Records the 9 outputs and 18 states at the
    end of every segment. Not accurate, but reproducible to the bit from the same FMU
    state, which is what it is for."""

    def __init__(self, fmu, h=ME_SUBSTEP, substeps=ME_SUBSTEPS):
        self.fmu, self.h, self.substeps = fmu, h, substeps
        self.x = np.zeros(N_STATES)
        self.dx = np.zeros(N_STATES)
        self.z = np.zeros(N_INDICATORS)
        self.z_prev = np.zeros(N_INDICATORS)
        self._px = self.x.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self._pdx = self.dx.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self._pz = self.z.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self._vr_in = (ctypes.c_uint32 * 5)(*fc.IN_VRS)
        self._vr_out = (ctypes.c_uint32 * 9)(*fc.OUT_VRS)
        self._val = (ctypes.c_double * 5)()
        self._out = (ctypes.c_double * 9)()
        self.state_events = 0

    def _event(self, inputs=None):
        f, comp = self.fmu, self.fmu.component
        assert f.fmi3EnterEventMode(comp) == FMI3_OK
        if inputs is not None:
            self._val[:] = [float(v) for v in inputs]
            assert f.fmi3SetFloat64(comp, self._vr_in, 5, self._val, 5) == FMI3_OK
        update_discrete_states(f)
        assert f.fmi3EnterContinuousTimeMode(comp) == FMI3_OK

    def run(self, t, U, start, stop):
        """Segments U[start:stop] (rows [vx, vy, steerRate, vsx, Fz]) from time t.
        Returns (Y (m, 9 + 18), t_end)."""
        from fmpy.fmi3 import fmi3Boolean

        f, comp = self.fmu, self.fmu.component
        enter, terminate = fmi3Boolean(), fmi3Boolean()
        Y = np.empty((stop - start, 9 + N_STATES))
        for i, k in enumerate(range(start, stop)):
            self._event(U[k])
            assert f.fmi3GetEventIndicators(comp, self._pz, N_INDICATORS) == FMI3_OK
            for _ in range(self.substeps):
                self.z_prev[:] = self.z
                assert f.fmi3GetContinuousStates(comp, self._px, N_STATES) == FMI3_OK
                assert f.fmi3GetContinuousStateDerivatives(comp, self._pdx, N_STATES) == FMI3_OK
                self.x += self.h * self.dx
                t += self.h
                assert f.fmi3SetTime(comp, t) == FMI3_OK
                assert f.fmi3SetContinuousStates(comp, self._px, N_STATES) == FMI3_OK
                assert f.fmi3CompletedIntegratorStep(comp, True, ctypes.byref(enter),
                                                     ctypes.byref(terminate)) == FMI3_OK
                assert not terminate.value
                assert f.fmi3GetEventIndicators(comp, self._pz, N_INDICATORS) == FMI3_OK
                crossed = ((self.z_prev < 0) & (self.z >= 0)) | ((self.z_prev > 0) & (self.z <= 0))
                if crossed.any() or enter.value:
                    self.state_events += 1
                    self._event()
                    assert f.fmi3GetEventIndicators(comp, self._pz, N_INDICATORS) == FMI3_OK
            assert f.fmi3GetFloat64(comp, self._vr_out, 9, self._out, 9) == FMI3_OK
            assert f.fmi3GetContinuousStates(comp, self._px, N_STATES) == FMI3_OK
            Y[i, :9] = self._out[:]
            Y[i, 9:] = self.x
        return Y, t


def me_inputs(n, seed):
    """Input rows for EulerME: the values of fmi4_common.input_sequence (vx through 0 and
    reversed, lift-off, a load ramp), each held for one 10 ms segment."""
    return fc.input_sequence(n, seed)["U"]
