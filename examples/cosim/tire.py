"""Tires for Python co-simulation masters: the TireLag FMU, and a tire without lag.

Conventions (docs/specification.md 2, README "Sign conventions"): every input and output is in the
wheel frame W, x forward along the wheel heading, y to the left, z up. Forces and moments
are those the tire applies to the wheel hub. The slip angle is alpha = -vy/|vx|; a
positive alpha gives a positive Fy. Units are SI: m/s, rad/s, N, N.m, m, rad.

Every tire here speaks the same small stepping protocol, which the master in
``coupling.py`` drives:

    y0 = tire.begin_step(u_start)      # set the coupled inputs at t_k, read the outputs
    tire.save()                        # remember the state at t_k (FMU state slot)
    y1 = tire.advance(h, u_start, u_end)   # ramp the inputs from u_start to u_end over h
    tire.restore()                     # back to t_k, to try another u_end

``u`` holds the tire's coupled inputs (``input_names``) and ``y`` its coupled outputs
(``output_names``), both as float arrays. Inputs that stay constant over a run (vx, Fz)
are set once with ``set_inputs``.

Either FMU works: the FMI 2.0 one (target/fmu/TireLag.fmu) steps the ramp exactly
(fmi2SetRealInputDerivatives); FMI 3.0 (target/fmu/fmi3/TireLag.fmu) has no input
derivatives, so there ``advance`` holds each input at the ramp's mean (u_start + u_end)/2
over the step, then sets u_end for the outputs at the end. The mean moves a velocity input's
integral (a deflection) by as much as the ramp does; the response differs from the ramp's
by O(h^2) (at angular frequency w the held signal's fundamental is sinc(w h) of the
samples, the ramp's sinc^2(w h/2): about (w h)^2/12 apart), and not at all for inputs
held constant. ``fmi.py`` tells the two FMUs apart.

The FMU is extracted once per process and FMU file: ``load_fmu`` caches the extraction
by the file's real path and SHA-256, so a Dask worker that runs many co-simulations
extracts it once.
"""

from __future__ import annotations

import atexit
import ctypes
import hashlib
import os
import shutil
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from . import fmi

# tireModel is an FMI Integer; its values are part of the FMU's documented interface.
TIRE_MODELS = {"RLT": 1, "DDT": 2, "SecondOrder": 3, "RingBody": 4}
# friction is an FMI Integer too (docs/specification.md 3); an FMU built before the friction limit
# has no such variable and behaves as Unlimited
FRICTION_LAWS = {"Unlimited": 1, "Coulomb": 2, "Brush": 3}
FMU_INPUTS = ("vx", "vy", "steerRate", "vsx", "Fz")
FMU_OUTPUTS = ("Fx", "Fy", "Mz", "My", "alphaT", "kappaT", "deflX", "deflY", "deflPsi")


# --------------------------------------------------------------------------- FMU file

@dataclass(frozen=True)
class FMUFile:
    """A TireLag FMU extracted on this machine, with its variables read by name."""

    path: str                         # the .fmu it came from (real path)
    sha256: str                       # of the .fmu bytes
    unzipdir: str                     # where it is extracted (removed at process exit)
    model_description: object         # fmpy ModelDescription
    value_references: Mapping[str, int]
    start_values: Mapping[str, float]  # Real and selector start values (parameters and inputs)

    @property
    def fmi_version(self) -> str:
        """fmi.FMI2 or fmi.FMI3."""
        return fmi.fmi_version(self.model_description, self.path)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(v.name for v in self.model_description.modelVariables
                     if v.causality == "parameter")

    def parameters(self, **overrides: float) -> dict[str, float]:
        """The Real parameters: their start values in the FMU, with `overrides`."""
        unknown = set(overrides) - set(self.parameter_names)
        if unknown:
            raise KeyError(f"not a TireLag parameter: {sorted(unknown)}")
        # The Real ones: not the Integer selectors, not the String tirFile.
        values = {name: self.start_values[name] for name in self.parameter_names
                  if name in self.start_values and name not in ("tireModel", "friction")}
        values.update({k: float(v) for k, v in overrides.items()})
        return values


_EXTRACTED: dict[tuple[str, str], FMUFile] = {}
_EXTRACTIONS = 0   # how many times this process unpacked an FMU (the sweep test reads it)
# A Dask worker with several threads runs several cases at once: one extraction for all.
_EXTRACTING = threading.Lock()


def _sha256(path: str) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def load_fmu(path: str | os.PathLike) -> FMUFile:
    """The extracted FMU at `path`, unpacked at most once per process and file content."""
    global _EXTRACTIONS
    from fmpy import extract, read_model_description

    real = os.path.realpath(path)
    if not os.path.isfile(real):
        raise FileNotFoundError(f"no FMU at {real} (build it with ./scripts/build-fmu)")
    key = (real, _sha256(real))
    with _EXTRACTING:
        cached = _EXTRACTED.get(key)
        if cached is not None:
            return cached
        md = read_model_description(real)
        fmi.fmi_version(md, real)          # an FMU of another FMI version: refused before unpacking
        unzipdir = tempfile.mkdtemp(prefix="tirelag-fmu-")
        atexit.register(shutil.rmtree, unzipdir, True)
        extract(real, unzipdir=unzipdir)
        _EXTRACTIONS += 1
        refs = {v.name: v.valueReference for v in md.modelVariables}
        fmu = FMUFile(real, key[1], unzipdir, md, refs, fmi.start_values(md))
        _EXTRACTED[key] = fmu
        return fmu


def extraction_count() -> int:
    """How many FMUs this process has unpacked so far."""
    return _EXTRACTIONS


# --------------------------------------------------------------------------- TireLag FMU

class TireLag:
    """One TireLag co-simulation instance (fmpy FMU2Slave or FMU3Slave: fmi.Slave),
    initialised and ready to step.

    model:       "RLT", "DDT", "SecondOrder" or "RingBody"
    parameters:  Real parameters by name (others keep their FMU start values); they are
                 fixed, so they are set here, before initialisation.
    inputs:      the coupled inputs, ramped by the master every step (e.g. ("vy",) or
                 ("vy", "steerRate")); every other input keeps the value set with
                 ``set_inputs`` (vx, Fz).
    outputs:     the outputs the master reads after every step.
    friction:    "Unlimited", "Coulomb" or "Brush" (docs/specification.md 4c), or None for the FMU's default.
                 The linear analyses of the examples ask for "Unlimited", which an FMU
                 without a friction limit already is.
    tir_file:    a tire property file (.tir) for the FMU's tirFile, or None; `parameters`
                 set explicitly keep their values, and ``self.parameters`` holds the values
                 in use after initialisation.
    """

    def __init__(self, fmu: FMUFile, model: str, parameters: Mapping[str, float] | None = None,
                 name: str = "tire", inputs: Sequence[str] = ("vy",),
                 outputs: Sequence[str] = ("Fy", "Mz", "deflY"), friction: str | None = None,
                 tir_file: str | os.PathLike | None = None):
        if model not in TIRE_MODELS:
            raise ValueError(f"unknown tire model {model!r}; one of {list(TIRE_MODELS)}")
        for n in inputs:
            if n not in FMU_INPUTS:
                raise ValueError(f"{n!r} is not a TireLag input")
        for n in outputs:
            if n not in FMU_OUTPUTS:
                raise ValueError(f"{n!r} is not a TireLag output")
        self.fmu = fmu
        self.model = model
        self.name = name
        self.input_names = tuple(inputs)
        self.output_names = tuple(outputs)
        self.parameters = fmu.parameters(**(parameters or {}))
        vr = fmu.value_references
        self._slave = fmi.Slave(fmu.model_description, fmu.unzipdir, name, fmu.path)
        self.fmi_version = self._slave.fmi_version
        self._slave.set_selector([vr["tireModel"]], [TIRE_MODELS[model]])
        if friction is not None:
            if friction not in FRICTION_LAWS:
                raise ValueError(f"unknown friction law {friction!r}; one of {list(FRICTION_LAWS)}")
            if "friction" in vr:
                self._slave.set_selector([vr["friction"]], [FRICTION_LAWS[friction]])
            elif friction != "Unlimited":
                raise ValueError(f"this FMU has no friction limit, so no {friction!r} friction")
        self.friction = friction
        if parameters:
            names = list(parameters)
            self._slave.set_real([vr[n] for n in names], [float(parameters[n]) for n in names])
        if tir_file is not None:
            self._slave.set_string([vr["tirFile"]], [os.fspath(tir_file)])
        self._slave.initialize(start_time=0.0)
        if tir_file is not None:
            names = list(self.parameters)
            self.parameters = dict(zip(names, self._slave.get_real([vr[n] for n in names])))
        self.time = 0.0
        self._saved_time = 0.0
        # ctypes buffers so that the per-step calls do not build lists
        n_in, n_out = len(self.input_names), len(self.output_names)
        self._in_refs = (ctypes.c_uint32 * n_in)(*[vr[n] for n in self.input_names])
        self._in_values = (ctypes.c_double * n_in)()
        self._in_rates = (ctypes.c_double * n_in)()
        self._in_orders = (ctypes.c_int32 * n_in)(*([1] * n_in))
        self._out_refs = (ctypes.c_uint32 * n_out)(*[vr[n] for n in self.output_names])
        self._out_values = (ctypes.c_double * n_out)()
        self._out_view = np.ctypeslib.as_array(self._out_values)
        self._n_in, self._n_out = n_in, n_out

    # ---------------------------------------------------------------- setup
    def set_inputs(self, **values: float) -> None:
        """Set inputs by name (vx, vy, steerRate, vsx, Fz), e.g. the constant vx of a run."""
        vr = self.fmu.value_references
        names = list(values)
        self._slave.set_real([vr[n] for n in names], [float(values[n]) for n in names])

    def read(self, *names: str) -> np.ndarray:
        """Any variables by name (outputs or inputs) at the current time."""
        vr = self.fmu.value_references
        return np.array(self._slave.get_real([vr[n] for n in names]))

    # ---------------------------------------------------------------- stepping protocol
    def begin_step(self, u_start: np.ndarray) -> np.ndarray:
        """Set the coupled inputs at the start of a step; return the coupled outputs."""
        self._set_coupled(u_start)
        self._slave.get_real_array(self._out_refs, self._n_out, self._out_values)
        return self._out_view.copy()

    def _set_coupled(self, u: np.ndarray) -> None:
        for i in range(self._n_in):
            self._in_values[i] = u[i]
        self._slave.set_real_array(self._in_refs, self._n_in, self._in_values)

    def save(self) -> None:
        self._slave.save_state()
        self._saved_time = self.time

    def restore(self) -> None:
        # the FMU state holds the states, the time, the inputs and their rates
        self._slave.restore_state()
        self.time = self._saved_time

    def advance(self, h: float, u_start: np.ndarray, u_end: np.ndarray) -> np.ndarray:
        """Step h seconds with each coupled input ramping linearly from u_start to u_end
        (FMI 2.0: fmi2SetRealInputDerivatives, order 1, and the FMU steps the ramp exactly;
        FMI 3.0: the ramp's mean held over the step, see the module doc). The inputs must
        already be at u_start (begin_step, or restore after it). Returns the outputs at the
        end of the step, with the inputs at u_end."""
        if self._slave.has_input_derivatives:
            inv_h = 1.0 / h
            for i in range(self._n_in):
                self._in_rates[i] = (u_end[i] - u_start[i]) * inv_h
            self._slave.ramp_inputs_array(self._in_refs, self._n_in, self._in_orders, self._in_rates)
            self._slave.do_step(self.time, h)
        else:
            self._set_coupled(0.5 * (np.asarray(u_start, float) + np.asarray(u_end, float)))
            self._slave.do_step(self.time, h)
            self._set_coupled(u_end)
        self.time += h
        self._slave.get_real_array(self._out_refs, self._n_out, self._out_values)
        return self._out_view.copy()

    def close(self) -> None:
        self._slave.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        return f"TireLag({self.name!r}, {self.model})"


# --------------------------------------------------------------------------- no lag

class SteadyStateTire:
    """A linear tire without lag, in Python: the force follows the slip at once.

        Fy = Calpha * alpha,  alpha = -vy/|vx|;   Mz = -trail * Fy;   alphaT = alpha.

    This is the tire of the "plain" bicycle model (Koo & Tan Appendix C, Kim's model
    without tau). It divides by the speed, so it is undefined at vx = 0.
    """

    OUTPUTS = ("Fy", "Mz", "alphaT")

    def __init__(self, Calpha: float, trail: float = 0.0, name: str = "tire",
                 inputs: Sequence[str] = ("vy",), outputs: Sequence[str] = ("Fy", "Mz")):
        for n in outputs:
            if n not in self.OUTPUTS:
                raise ValueError(f"SteadyStateTire has no output {n!r} (it has {self.OUTPUTS})")
        self.name = name
        self.model = "no lag"
        self.Calpha = float(Calpha)
        self.trail = float(trail)
        self.input_names = tuple(inputs)
        self.output_names = tuple(outputs)
        self.vx = float("nan")
        self.time = 0.0
        self._saved_time = 0.0

    def set_inputs(self, **values: float) -> None:
        if "vx" in values:
            self.vx = float(values["vx"])

    def _outputs(self, u: np.ndarray) -> np.ndarray:
        if not abs(self.vx) > 0.0:
            raise ValueError(f"{self.name}: a tire without lag is undefined at vx = {self.vx}")
        inputs = dict(zip(self.input_names, u))
        alpha = -inputs.get("vy", 0.0) / abs(self.vx)
        Fy = self.Calpha * alpha
        values = {"Fy": Fy, "Mz": -self.trail * Fy, "alphaT": alpha}
        return np.array([values[n] for n in self.output_names])

    def begin_step(self, u_start: np.ndarray) -> np.ndarray:
        return self._outputs(u_start)

    def save(self) -> None:
        self._saved_time = self.time

    def restore(self) -> None:
        self.time = self._saved_time

    def advance(self, h: float, u_start: np.ndarray, u_end: np.ndarray) -> np.ndarray:
        self.time += h
        return self._outputs(u_end)

    def close(self) -> None:
        pass

    def __repr__(self):
        return f"SteadyStateTire({self.name!r}, Calpha={self.Calpha:g})"


def default_fmu_path() -> Path:
    """$TIRELAG_FMU if set, else <project>/target/fmu/TireLag.fmu (the FMI 2.0 FMU)."""
    env = os.environ.get("TIRELAG_FMU")
    if env:
        return Path(env)
    return fmi.FMU2_PATH


