"""Shared fixtures for the TireLag FMU tests.

The FMU is <repo>/target/fmu/TireLag.fmu (repo = two levels above this folder). It is
extracted once per session. ``make_tire`` creates initialised FMU2Slave instances through
the small ``Tire`` helper below and frees them at the end of each test.
"""

from __future__ import annotations

import ctypes
import os
import sys
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import friction_reference as fr  # noqa: E402
import reference as ref  # noqa: E402

REPO = HERE.parents[1]
FMU_PATH = REPO / "target" / "fmu" / "TireLag.fmu"

_IN_ALL = [ref.INPUT_VR[n] for n in ref.INPUTS]                  # vx vy steerRate vsx Fz
_IN_DRIVING = [ref.INPUT_VR[n] for n in ref.DRIVING]             # vy steerRate vsx
_OUT_ALL = [ref.OUTPUT_VR[n] for n in ref.OUTPUTS]


def has_friction(model_description):
    """True if the FMU declares the friction selector of docs/specification.md 4c."""
    return any(v.name == "friction" for v in model_description.modelVariables)


def _uint_array(values):
    return (ctypes.c_uint32 * len(values))(*values)


class Tire:
    """An initialised TireLag co-simulation instance.

    >>> tire = Tire(md, unzipdir, model="RLT", params={"sigmaY": 0.8}, vx=5.0)
    >>> Y = tire.run(U, h)          # U: (N, 3) [vy, steerRate, vsx] held over each step
    """

    def __init__(self, model_description, unzipdir, model="DDT", params=None,
                 vx=0.0, vy=0.0, steerRate=0.0, vsx=0.0, Fz=None, name="tire",
                 friction="Unlimited"):
        """friction: "Unlimited" (default, so the linear tests stay linear), "Coulomb" or
        "Brush" (docs/specification.md 4c); set only if the FMU declares the `friction` variable."""
        from fmpy.fmi2 import FMU2Slave

        self.md = model_description
        self.model = model
        self.params = fr.parameters(**(params or {}))
        self.fmu = FMU2Slave(guid=model_description.guid, unzipDirectory=unzipdir,
                             modelIdentifier=model_description.coSimulation.modelIdentifier,
                             instanceName=name)
        self.fmu.instantiate()
        self._alive = True
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.setInteger([ref.MODEL_VR], [ref.MODELS[model]])
        if has_friction(model_description):
            self.fmu.setInteger([fr.FRICTION_VR], [fr.FRICTION_LAWS[friction]])
        if params:
            names = list(params)
            vrs = {**ref.PARAMETER_VR, **fr.FRICTION_PARAMETER_VR}
            self.fmu.setReal([vrs[n] for n in names], [float(params[n]) for n in names])
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.t = 0.0
        # preallocated ctypes buffers for the fast loops
        self._vr_all = _uint_array(_IN_ALL)
        self._vr_drv = _uint_array(_IN_DRIVING)
        self._vr_out = _uint_array(_OUT_ALL)
        self._val_all = (ctypes.c_double * 5)()
        self._val_drv = (ctypes.c_double * 3)()
        self._rate_drv = (ctypes.c_double * 3)()
        self._order_drv = (ctypes.c_int * 3)(1, 1, 1)
        self._out = (ctypes.c_double * 9)()
        self._out_np = np.ctypeslib.as_array(self._out)
        inputs = dict(vx=vx, vy=vy, steerRate=steerRate, vsx=vsx)
        if Fz is not None:
            inputs["Fz"] = Fz
        self.set(**inputs)

    # ---------------------------------------------------------------- basic calls
    def set(self, **inputs):
        names = list(inputs)
        self.fmu.setReal([ref.INPUT_VR[n] for n in names], [float(inputs[n]) for n in names])

    def set_rates(self, **rates):
        names = list(rates)
        self.fmu.setRealInputDerivatives([ref.INPUT_VR[n] for n in names], [1] * len(names),
                                         [float(rates[n]) for n in names])

    def get(self, *names):
        return np.array(self.fmu.getReal([ref.OUTPUT_VR[n] for n in names]))

    def outputs(self):
        """All nine outputs in ref.OUTPUTS order."""
        self.fmu.fmi2GetReal(self.fmu.component, self._vr_out, 9, self._out)
        return self._out_np.copy()

    def step(self, h):
        self.fmu.fmi2DoStep(self.fmu.component, self.t, h, 1)
        self.t += h

    # ---------------------------------------------------------------- sequences
    def run(self, U, h, dU=None, vx=None, Fz=None):
        """Drive the FMU with inputs held (or ramped) over steps; returns (N, 9) outputs.

        U:  (N, 3) [vy, steerRate, vsx] set before each step.
        dU: (N, 3) input rates set before each step (ramps), or None.
        vx, Fz: None (leave as is) or arrays with one value per step.
        h:  scalar or array of step sizes.
        """
        U = np.atleast_2d(np.asarray(U, dtype=float))
        N = U.shape[0]
        hs = np.broadcast_to(np.asarray(h, dtype=float), (N,))
        Y = np.empty((N, 9))
        f = self.fmu
        comp = f.component
        vxs = None if vx is None else np.broadcast_to(np.asarray(vx, float), (N,))
        fzs = None if Fz is None else np.broadcast_to(np.asarray(Fz, float), (N,))
        vr_vx = _uint_array([ref.INPUT_VR["vx"]])
        vr_fz = _uint_array([ref.INPUT_VR["Fz"]])
        one = (ctypes.c_double * 1)()
        for k in range(N):
            if vxs is not None:
                one[0] = vxs[k]
                f.fmi2SetReal(comp, vr_vx, 1, one)
            if fzs is not None:
                one[0] = fzs[k]
                f.fmi2SetReal(comp, vr_fz, 1, one)
            self._val_drv[0], self._val_drv[1], self._val_drv[2] = U[k]
            f.fmi2SetReal(comp, self._vr_drv, 3, self._val_drv)
            if dU is not None:
                self._rate_drv[0], self._rate_drv[1], self._rate_drv[2] = dU[k]
                f.fmi2SetRealInputDerivatives(comp, self._vr_drv, 3, self._order_drv, self._rate_drv)
            f.fmi2DoStep(comp, self.t, float(hs[k]), 1)
            self.t += float(hs[k])
            f.fmi2GetReal(comp, self._vr_out, 9, self._out)
            Y[k] = self._out_np
        return Y

    def wheel_loop(self, m_w, v, F, h, F_ext=None):
        """Fast inner loop of harness.wheel_cosim (same coupling, direct ctypes calls)."""
        f = self.fmu
        comp = f.component
        vr_vy = _uint_array([ref.INPUT_VR["vy"]])
        vr_fy = _uint_array([ref.OUTPUT_VR["Fy"]])
        val = (ctypes.c_double * 1)()
        out = (ctypes.c_double * 1)()
        for k in range(len(v) - 1):
            val[0] = v[k]
            f.fmi2SetReal(comp, vr_vy, 1, val)
            f.fmi2DoStep(comp, self.t, h, 1)
            self.t += h
            f.fmi2GetReal(comp, vr_fy, 1, out)
            F[k + 1] = out[0]
            v[k + 1] = v[k] + h * (out[0] + (0.0 if F_ext is None else F_ext[k])) / m_w

    def close(self):
        if self._alive:
            self._alive = False
            try:
                self.fmu.terminate()
            finally:
                self.fmu.freeInstance()


# --------------------------------------------------------------------------- fixtures

@pytest.fixture(scope="session")
def fmu_path():
    if not FMU_PATH.is_file():
        pytest.fail(f"FMU not found: {FMU_PATH} (build it with ./scripts/build-fmu)")
    return str(FMU_PATH)


@pytest.fixture(scope="session")
def example_fmu(request):
    """The FMU the examples run: $TIRELAG_FMU if set, else the built one."""
    env = os.environ.get("TIRELAG_FMU")
    if env:
        return str(Path(env).resolve())
    return request.getfixturevalue("fmu_path")


FMU3_PATH = REPO / "target" / "fmu" / "fmi3" / "TireLag.fmu"


@pytest.fixture(scope="module", params=["fmi2", "fmi3"])
def either_fmu(request, example_fmu):
    """The FMU an example runs on: the FMI 2.0 one (example_fmu), then the FMI 3.0 one."""
    if request.param == "fmi2":
        return example_fmu
    assert FMU3_PATH.is_file(), f"no FMI 3.0 FMU at {FMU3_PATH}: build it with ./scripts/build-fmu"
    return str(FMU3_PATH)


@pytest.fixture(scope="session")
def unzipdir(fmu_path, tmp_path_factory):
    from fmpy import extract

    return extract(fmu_path, unzipdir=str(tmp_path_factory.mktemp("TireLag")))


@pytest.fixture(scope="session")
def model_description(fmu_path):
    from fmpy import read_model_description

    return read_model_description(fmu_path)


@pytest.fixture
def make_tire(model_description, unzipdir):
    """make_tire(model, params=None, vx=0, ...) -> Tire; all are freed after the test."""
    tires = []

    def factory(model="DDT", params=None, **inputs):
        tire = Tire(model_description, unzipdir, model=model, params=params,
                    name=f"tire{len(tires)}", **inputs)
        tires.append(tire)
        return tire

    yield factory
    for tire in tires:
        tire.close()


# --------------------------------------------------------------------------- helpers

def assert_close_run(Y, Yref, rtol=1e-9, atol=1e-12, label=""):
    """|y - yref| <= rtol * max|yref over the run| + atol, per output column."""
    Y = np.asarray(Y)
    Yref = np.asarray(Yref)
    assert Y.shape == Yref.shape
    assert np.all(np.isfinite(Y)), f"{label}: non-finite outputs"
    scale = np.max(np.abs(Yref), axis=0)
    err = np.abs(Y - Yref)
    bound = rtol * scale + atol
    bad = err > bound
    if np.any(bad):
        cols = sorted(set(np.nonzero(bad)[1]))
        lines = []
        for c in cols:
            k = int(np.argmax(err[:, c] / bound[c]))
            lines.append(f"{ref.OUTPUTS[c]}: max |err| {err[:, c].max():.3e} (scale {scale[c]:.3e}, "
                         f"rel {err[:, c].max() / max(scale[c], 1e-300):.3e}); worst at step {k}: "
                         f"fmu {Y[k, c]:.12e} ref {Yref[k, c]:.12e}")
        raise AssertionError(f"{label}: outputs differ from the exact solution\n  " + "\n  ".join(lines))


def seed(*key):
    """A reproducible RNG seed from test parameters (str hashes are salted per process)."""
    import zlib

    return zlib.crc32(repr(key).encode())


def random_steps(rng, n_steps, hold, amplitudes):
    """Piecewise-constant random signals: (n_steps, len(amplitudes)), new values every `hold` steps."""
    n_blocks = -(-n_steps // hold)
    values = rng.uniform(-1.0, 1.0, size=(n_blocks, len(amplitudes))) * np.asarray(amplitudes, float)
    return np.repeat(values, hold, axis=0)[:n_steps]
