"""A second, independent importer: OSP libcosim (C++ FMI Library based) through the
`libcosimpy` package (installed by ./scripts/setup from requirements.txt).

The FMU is run in a libcosim execution with a fixed step: parameters as initial values,
the inputs driven step by step with an override manipulator, the outputs read with a
last-value observer. The same sequence run in fmpy must give the same outputs to 1e-12
relative (libcosim counts time in integer nanoseconds, so its step sizes may differ from
fmpy's in the last bit; the FMU is exact for any step, so the results agree to rounding).

libcosim ignores Enumeration variables (open-simulation-platform/libcosim#246, #670:
"enums are ignored with a warning"), so the selectors are Integer variables: libcosim
sees `tireModel` and sets it with fmi2SetInteger on the FMU exactly as shipped. The test
also checks that libcosim lists it as an Integer, so a change back to Enumeration fails here.
"""

from __future__ import annotations

import numpy as np
import pytest

import fmi4_common as fc

try:
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave
    from libcosimpy._internal import get_last_error_message
except ImportError as e:  # a missing install is a failure, not a skip
    raise ImportError(f"libcosimpy is not installed ({e}): "
                      "run ./scripts/setup") from e

H_NS = 1_000_000          # 1 ms in nanoseconds
H = 1e-3
N_STEPS = 1500

PARAMS = {"Calpha": 280000.0, "sigmaY": 0.9, "dampingY": 7000.0, "trail": 0.045,
          "Ckappa": 450000.0, "sigmaX": 0.45, "Re": 0.58}


def _sequence(n, seed):
    """Per step: [vx, vy, steerRate, vsx, Fz]; vx passes through 0 and reverses, Fz lifts off."""
    rng = np.random.default_rng(seed)
    hold = 50
    nb = -(-n // hold)
    vx = np.repeat(rng.choice([-4.0, 0.0, 0.8, 1.6, 15.0], size=nb), hold)[:n]
    drv = np.repeat(rng.uniform(-1, 1, size=(nb, 3)) * [0.3, 0.25, 0.2], hold, axis=0)[:n]
    fz = np.full(n, 50000.0)
    fz[n // 2: n // 2 + 60] = 0.0
    return np.column_stack([vx, drv, fz])


@pytest.fixture(scope="module", autouse=True)
def quiet_libcosim():
    log_output_level(CosimLogLevel.ERROR)


def run_libcosim(fmu_path, model, params, U, friction=None):
    ex = CosimExecution.from_step_size(H_NS)
    slave = CosimLocalSlave(fmu_path=str(fmu_path), instance_name="tire")
    idx = ex.add_local_slave(slave)
    assert idx >= 0, get_last_error_message()
    variables = {v.name.decode(): (v.reference, v.type) for v in ex.slave_variables(idx)}
    assert {n for n in fc.INPUTS + fc.OUTPUTS} <= set(variables)
    assert variables["tireModel"][0] == fc.MODEL_VR, "libcosim must see the tireModel selector"
    assert variables["friction"][0] == fc.FRICTION_VR, "libcosim must see the friction selector"
    manipulator = CosimManipulator.create_override()
    observer = CosimObserver.create_last_value()
    assert ex.add_manipulator(manipulator), get_last_error_message()
    assert ex.add_observer(observer), get_last_error_message()
    if model is not None:
        assert ex.integer_initial_value(idx, fc.MODEL_VR, fc.MODELS[model]), get_last_error_message()
    if friction is not None:
        assert ex.integer_initial_value(idx, fc.FRICTION_VR, fc.FRICTIONS[friction]), get_last_error_message()
    for name, value in params.items():
        assert ex.real_initial_value(idx, fc.ALL_PARAMETER_VR[name], value), get_last_error_message()
    for name, value in zip(fc.INPUTS, U[0]):
        assert ex.real_initial_value(idx, fc.INPUT_VR[name], float(value)), get_last_error_message()
    Y = np.empty((len(U), 9))
    for k in range(len(U)):
        assert manipulator.slave_real_values(idx, fc.IN_VRS, [float(v) for v in U[k]]), get_last_error_message()
        assert ex.step(1), f"libcosim step {k} failed: {get_last_error_message()}"
        Y[k] = observer.last_real_values(idx, fc.OUT_VRS)
    status = ex.status()
    assert status.current_time == len(U) * H_NS
    del ex, slave, manipulator, observer
    return Y


def run_fmpy(model, params, U, unzipdir, md, friction=None):
    s = fc.new_slave(md, unzipdir, name="fmpy")
    try:
        fc.initialise(s, model, params, friction=friction)
        Y = np.empty((len(U), 9))
        t = 0.0
        for k in range(len(U)):
            s.setReal(fc.IN_VRS, [float(v) for v in U[k]])
            s.doStep(t, H)
            t += H
            Y[k] = fc.outputs(s)
        return Y
    finally:
        fc.close(s)


@pytest.fixture(scope="module")
def fmpy_fmu(tmp_path_factory):
    return fc.read_md(), fc.extract_fmu(tmp_path_factory.mktemp("fmi4_libcosim_fmpy"))


def assert_same(Y, Yref, label):
    assert np.all(np.isfinite(Y)), f"{label}: non-finite libcosim outputs"
    scale = np.abs(Yref).max(0)
    err = np.abs(Y - Yref)
    bad = np.nonzero((err > 1e-12 * scale + 1e-300).any(0))[0]
    assert bad.size == 0, f"{label}:\n  " + "\n  ".join(
        f"{fc.OUTPUTS[i]}: max |diff| {err[:, i].max():.3e} (scale {scale[i]:.3e})" for i in bad)


def test_libcosim_runs_the_packed_fmu_like_fmpy(fmpy_fmu):
    """The FMU exactly as packed, nothing set but parameters: the default model (DDT)."""
    md, unzipdir = fmpy_fmu
    U = _sequence(N_STEPS, 1)
    Y = run_libcosim(fc.FMU_PATH, None, PARAMS, U)
    Yref = run_fmpy("DDT", PARAMS, U, unzipdir, md)
    assert np.abs(Yref[:, fc.OUTPUTS.index("Fy")]).max() > 100.0
    assert_same(Y, Yref, "DDT")


@pytest.mark.parametrize("model", list(fc.MODELS))
def test_libcosim_selects_every_model_on_the_shipped_fmu(fmpy_fmu, model):
    md, unzipdir = fmpy_fmu
    U = _sequence(N_STEPS, 2 + fc.MODELS[model])
    Y = run_libcosim(fc.FMU_PATH, model, PARAMS, U)
    Yref = run_fmpy(model, PARAMS, U, unzipdir, md)
    assert_same(Y, Yref, model)
    # the model really was switched: every other model differs on the same inputs
    for other in fc.MODELS:
        if other != model:
            assert not np.allclose(Y, run_fmpy(other, PARAMS, U, unzipdir, md)), (model, other)


@pytest.mark.parametrize("friction", list(fc.FRICTIONS))
def test_libcosim_selects_every_friction_law_on_the_shipped_fmu(fmpy_fmu, friction):
    """libcosim sets the friction selector (an Integer, like tireModel) and the friction
    coefficients; with mu = 0.1 the laws differ on these inputs, and each matches fmpy."""
    md, unzipdir = fmpy_fmu
    U = _sequence(N_STEPS, 11)
    params = {**PARAMS, "muX": 0.1, "muY": 0.1}
    Y = run_libcosim(fc.FMU_PATH, "RLT", params, U, friction)
    Yref = run_fmpy("RLT", params, U, unzipdir, md, friction)
    assert_same(Y, Yref, friction)
    for other in fc.FRICTIONS:
        if other != friction:
            assert not np.allclose(Y, run_fmpy("RLT", params, U, unzipdir, md, other)), (friction, other)
