"""Small helpers for the FMI-behaviour tests (state, derivatives, bad input, libcosim).

Independent of conftest.Tire on purpose: these tests need instances that capture the
FMU's log messages, instances that are only instantiated (not initialised), and the raw
status of every call. Everything here goes through fmpy.fmi2.FMU2Slave.
"""

from __future__ import annotations

import contextlib
import ctypes
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
FMU_PATH = REPO / "target" / "fmu" / "TireLag.fmu"

MODELS = {"RLT": 1, "DDT": 2, "SecondOrder": 3, "RingBody": 4}
INPUTS = ["vx", "vy", "steerRate", "vsx", "Fz"]
INPUT_VR = {"vx": 1, "vy": 2, "steerRate": 3, "vsx": 4, "Fz": 5}
OUTPUTS = ["Fx", "Fy", "Mz", "My", "alphaT", "kappaT", "deflX", "deflY", "deflPsi"]
OUTPUT_VR = dict(zip(OUTPUTS, range(11, 20)))
IN_VRS = [INPUT_VR[n] for n in INPUTS]
OUT_VRS = [OUTPUT_VR[n] for n in OUTPUTS]
DRIVING_VRS = [INPUT_VR[n] for n in ("vy", "steerRate", "vsx")]
from reference import MODEL_VR, PARAMETER_VR  # noqa: E402  (one table of value references)
FRICTION_VR = 121
FRICTIONS = {"Unlimited": 1, "Coulomb": 2, "Brush": 3}
FRICTION_PARAMETER_VR = {"muX": 122, "muY": 123, "muLoadSensitivity": 124, "boreRadius": 125}
ALL_PARAMETER_VR = {**PARAMETER_VR, **FRICTION_PARAMETER_VR}
# Model Exchange: the continuous states (docs/specification.md 7b) and event indicators, both versions.
N_STATES = 18
N_INDICATORS = 9
STATE_NAMES = ([f"tireState{i}" for i in range(1, 7)]
               + [f"sliderOffset{d}{i}" for d in ("X", "Y", "Psi") for i in range(1, 5)])
VR_NAME = {vr: n for n, vr in {**INPUT_VR, **OUTPUT_VR, **PARAMETER_VR, **FRICTION_PARAMETER_VR,
                               "tireModel": MODEL_VR, "friction": FRICTION_VR}.items()}

FMI2_OK, FMI2_WARNING, FMI2_DISCARD, FMI2_ERROR = 0, 1, 2, 3

# fmpy's logger proxy (fmpy.logging.addLoggerProxy) keeps the Python logger it was last
# given in one global of its native library, and every proxied callback table, fmpy's
# defaultCallbacks included, forwards there. A logger freed while it is that global
# would be called later by any instance that logs through fmpy's defaults: each one is
# kept for the life of the process.
_PROXIED_LOGGERS = []


class MessageLog:
    """The (status, category, message) of every log call, the texts decoded from bytes.
    The common part of LogCapture (FMI 2.0) and fmi3_common.LogCapture3 (FMI 3.0), whose
    error status is 3 in both versions."""

    def __init__(self):
        self.messages = []

    def record(self, status, category, message):
        self.messages.append((int(status), (category or b"").decode("utf-8", "replace"),
                              (message or b"").decode("utf-8", "replace")))

    def clear(self):
        self.messages.clear()

    def errors(self):
        return [m for (s, _, m) in self.messages if s >= FMI2_ERROR]

    def text(self):
        return "\n".join(f"[{s}] {c}: {m}" for s, c, m in self.messages)


class LogCapture(MessageLog):
    """fmi2CallbackFunctions whose logger records (status, category, message).

    With `formatting` (the default), fmpy's logger proxy (fmpy.logging.addLoggerProxy)
    formats the variadic C call first, so the Python callback receives the final text, as
    fmpy.simulate_fmu(logger=...) does. Without it the callback is a plain ctypes function
    that receives the message argument as it comes, as FMI.jl and many hand-written masters
    do.
    """

    def __init__(self, formatting=True):
        import fmpy
        from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                               fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
        from fmpy.logging import addLoggerProxy

        super().__init__()

        def logger(component, instance_name, status, category, message):
            self.record(status, category, message)

        self._logger = logger
        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(logger)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(fmpy.calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(fmpy.free)
        if formatting:
            addLoggerProxy(ctypes.byref(cb))
            _PROXIED_LOGGERS.append(cb.logger)
        self.callbacks = cb


def extract_fmu(dest):
    from fmpy import extract

    return extract(str(FMU_PATH), unzipdir=str(dest))


def configuration_readback(get_integer, get_real, parameters):
    """What an instance reports of its configuration (selectors, the `parameters` by name
    and value reference, inputs) through one FMI version's integer and real getters."""
    return {
        "model": get_integer([MODEL_VR])[0],
        "friction": get_integer([FRICTION_VR])[0],
        "params": dict(zip(parameters, get_real(list(parameters.values())))),
        "inputs": get_real(IN_VRS),
    }


def read_md():
    from fmpy import read_model_description

    return read_model_description(str(FMU_PATH))


def new_slave(md, unzipdir, name="tire", log=None, logging_on=False):
    """An FMU2Slave that is only instantiated (phase 'instantiated')."""
    from fmpy.fmi2 import FMU2Slave

    slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir,
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    slave.instantiate(callbacks=None if log is None else log.callbacks, loggingOn=logging_on)
    return slave


def counting_model_class(base):
    """fmpy's FMU2Model or FMU3Model (`base`) subclassed to count enterEventMode calls
    (input and state events) in `n_events`: FMU2CountingModel or FMU3CountingModel (fmpy
    picks the FMI version of the functions it loads from the class name's prefix)."""

    class CountingModel(base):
        n_events = 0

        def enterEventMode(self):
            self.n_events += 1
            return super().enterEventMode()

    CountingModel.__name__ = base.__name__.replace("Model", "CountingModel")
    return CountingModel


def initialise(slave, model="DDT", params=None, inputs=None, start_time=0.0, friction=None):
    """setupExperiment, parameters, model and friction law (None: the FMU's default,
    Brush), enter/exit initialisation, then inputs."""
    slave.setupExperiment(startTime=start_time)
    if model is not None:
        slave.setInteger([MODEL_VR], [MODELS[model]])
    if friction is not None:
        slave.setInteger([FRICTION_VR], [FRICTIONS[friction]])
    if params:
        vrs = {**PARAMETER_VR, **FRICTION_PARAMETER_VR}
        slave.setReal([vrs[k] for k in params], [float(v) for v in params.values()])
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    if inputs:
        slave.setReal([INPUT_VR[k] for k in inputs], [float(v) for v in inputs.values()])
    return slave


def module_fmu(tmp_path_factory, name):
    """(model description, unzip directory): the body of a module-scoped `fmu` fixture."""
    return read_md(), extract_fmu(tmp_path_factory.mktemp(name))


def run_state_worker(script, out):
    """`python script save out`, then `python script load out`, each in a fresh process
    (fmi4_state_worker.py, fmi3_state_worker.py); both must succeed. Returns out."""
    for mode in ("save", "load"):
        r = subprocess.run([sys.executable, script, mode, str(out)],
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, f"worker {mode} failed ({r.returncode}):\n{r.stdout}\n{r.stderr}"
    return out


def start_values(md):
    """Start value of every numeric variable by name (None where there is none)."""
    return {v.name: (None if v.start is None else float(v.start))
            for v in md.modelVariables if v.type != "String"}


@contextlib.contextmanager
def slave_factory(md, unzipdir, prefix):
    """Yields new(model, params, inputs, log, init) -> slave; frees every slave at the end."""
    made = []

    def new(model="DDT", params=None, inputs=None, log=None, init=True, friction=None):
        s = new_slave(md, unzipdir, name=f"{prefix}{len(made)}", log=log)
        made.append(s)
        if init:
            initialise(s, model, params, inputs, friction=friction)
        return s

    try:
        yield new
    finally:
        for s in made:
            close(s)


def close(slave):
    try:
        slave.terminate()
    except Exception:
        pass
    slave.freeInstance()


def outputs(slave):
    return np.array(slave.getReal(OUT_VRS))


def status_of(call, *args):
    """Run an fmpy call; return (status, result). FMICallException -> its status."""
    from fmpy.fmi1 import FMICallException

    try:
        return FMI2_OK, call(*args)
    except FMICallException as e:
        return e.status, None


# --------------------------------------------------------------------------- input sequences

def input_sequence(n, seed):
    """A deterministic, varied input sequence for n communication steps.

    Returns a dict of arrays: h (n,), U (n, 5) input values [vx, vy, steerRate, vsx, Fz],
    set_mask (n,) whether the inputs are set before the step (otherwise the FMU's held
    or ramped values are used), R (n, 3) rates of [vy, steerRate, vsx], rate_mask (n,).
    vx changes sign and passes through 0; Fz drops to 0 (lift-off) for a while.
    """
    rng = np.random.default_rng(seed)
    hold = 25
    nb = -(-n // hold)
    vx = np.repeat(rng.choice([-6.0, -0.3, 0.0, 0.7, 1.6, 12.0, 25.0], size=nb), hold)[:n]
    drv = np.repeat(rng.uniform(-1, 1, size=(nb, 3)) * [0.4, 0.3, 0.5], hold, axis=0)[:n]
    fz = np.full(n, 50000.0)
    fz[n // 3: n // 3 + 40] = 0.0
    fz[n // 2: n // 2 + 30] = 42000.0 + 100.0 * np.arange(30)
    U = np.column_stack([vx, drv, fz])
    R = rng.uniform(-2.0, 2.0, size=(n, 3))
    h = rng.choice([1e-3, 2.5e-3, 1e-2, 0.05], size=n)
    k = np.arange(n)
    return {"h": h, "U": U, "set_mask": (k % 7) != 0, "R": R, "rate_mask": (k % 5) == 0}


def drive(slave, t, seq, start=0, stop=None):
    """Run seq[start:stop] on slave from time t. Returns (Y (m, 9), t_end)."""
    f = slave
    comp = f.component
    stop = len(seq["h"]) if stop is None else stop
    vr_in = (ctypes.c_uint32 * 5)(*IN_VRS)
    vr_drv = (ctypes.c_uint32 * 3)(*DRIVING_VRS)
    vr_out = (ctypes.c_uint32 * 9)(*OUT_VRS)
    order = (ctypes.c_int * 3)(1, 1, 1)
    val = (ctypes.c_double * 5)()
    rate = (ctypes.c_double * 3)()
    out = (ctypes.c_double * 9)()
    Y = np.empty((stop - start, 9))
    for i, k in enumerate(range(start, stop)):
        if seq["set_mask"][k]:
            val[:] = [float(v) for v in seq["U"][k]]
            assert f.fmi2SetReal(comp, vr_in, 5, val) == FMI2_OK
        if seq["rate_mask"][k]:
            rate[:] = [float(v) for v in seq["R"][k]]
            assert f.fmi2SetRealInputDerivatives(comp, vr_drv, 3, order, rate) == FMI2_OK
        h = float(seq["h"][k])
        assert f.fmi2DoStep(comp, t, h, 1) == FMI2_OK
        t += h
        assert f.fmi2GetReal(comp, vr_out, 9, out) == FMI2_OK
        Y[i] = out[:]
    return Y, t


# Non-default parameters for the state tests (all consistent for every model).
# Friction low enough that the state tests' inputs make the elements slide.
STATE_FRICTION_PARAMS = {"muX": 0.25, "muY": 0.3, "muLoadSensitivity": -0.2, "boreRadius": 0.05}
# (model, friction law) pairs of the cross-process state test.
STATE_CASES = [(m, "Unlimited") for m in MODELS] + [(m, law) for m in MODELS for law in ("Coulomb", "Brush")]

STATE_PARAMS = {
    "Calpha": 210000.0, "Ckappa": 330000.0, "sigmaY": 0.8, "sigmaX": 0.4, "Re": 0.55,
    "trail": 0.04, "Fz0": 42000.0, "dampingY": 6000.0, "dampingX": 7000.0, "sigmaPsi": 0.35,
    "stiffnessPsi": 30000.0, "dampingPsi": 300.0, "contactMass": 15.0,
    "carcassDampingY": 8000.0, "ringMass": 25.0, "ringInertia": 6.0, "ringDampingY": 8500.0,
    "ringDampingX": 7500.0, "sigmaTread": 0.12, "calphaLoadPeak": 1.7,
}
