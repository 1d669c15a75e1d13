"""Property tests (hypothesis) over random valid parameters and input sequences.

* no NaN or infinity in any output, for any model, parameters, speeds, steps and loads;
* the result does not depend on how the importer chops time (docs/specification.md 6);
* the FMU equals the exact reference solution for random physical parameters.
"""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import reference as ref
from conftest import assert_close_run

SETTINGS = settings(max_examples=40, deadline=None, database=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow])


def log_uniform(lo, hi):
    return st.floats(np.log10(lo), np.log10(hi)).map(lambda e: float(10.0 ** e))


@st.composite
def valid_parameters(draw, wide=True):
    """Random parameters inside the valid domain (docs/specification.md 3 and 8)."""
    span = (1e-3, 1e3) if wide else (0.2, 5.0)

    def scaled(name):
        return float(ref.DEFAULTS[name] * draw(log_uniform(*span)))

    def damping(name):
        if wide and draw(st.booleans()):
            return 0.0
        return scaled(name)

    p = {}
    for name in ("Calpha", "Ckappa", "Re", "Fz0", "stiffnessPsi", "contactMass", "ringMass",
                 "ringInertia", "sigmaPsi"):
        p[name] = scaled(name)
    for name in ("dampingY", "dampingX", "dampingPsi", "carcassDampingY", "ringDampingY", "ringDampingX"):
        p[name] = damping(name)
    lengths = (0.01, 10.0) if wide else (0.3, 3.0)
    p["sigmaY"] = draw(log_uniform(*lengths))
    p["sigmaX"] = draw(log_uniform(*lengths))
    frac = draw(st.floats(0.001, 0.95) if wide else st.floats(0.05, 0.6))
    p["sigmaTread"] = frac * min(p["sigmaY"], p["sigmaX"])
    p["trail"] = draw(st.floats(-0.3, 0.3))
    return p


speeds = st.one_of(st.just(0.0), st.floats(-100.0, 100.0), st.sampled_from([1e-9, -1e-6, 0.45, -100.0, 100.0]))
steps = st.one_of(log_uniform(1e-6, 10.0), st.sampled_from([1e-6, 1e-3, 0.5, 10.0]))
values = st.floats(-20.0, 20.0)
loads = st.one_of(st.floats(-1e5, 2e5), st.just(0.0))


@st.composite
def input_sequences(draw, max_len=25):
    n = draw(st.integers(1, max_len))
    rows = draw(st.lists(st.tuples(speeds, steps, values, values, values, loads, values, values, values),
                         min_size=n, max_size=n))
    return rows


@SETTINGS
@given(model=st.sampled_from(ref.MODEL_NAMES), params=valid_parameters(wide=True), seq=input_sequences(),
       ramp=st.booleans())
def test_outputs_always_finite(make_tire, model, params, seq, ramp):
    tire = make_tire(model, params=params)
    assert np.all(np.isfinite(tire.outputs()))
    for vx, h, vy, r, vsx, Fz, dvy, dr, dvsx in seq:
        tire.set(vx=vx, vy=vy, steerRate=r, vsx=vsx, Fz=Fz)
        if ramp:
            tire.set_rates(vy=dvy, steerRate=dr, vsx=dvsx)
        y = tire.outputs()
        assert np.all(np.isfinite(y)), f"non-finite outputs before a step: {dict(zip(ref.OUTPUTS, y))}"
        tire.step(h)
        y = tire.outputs()
        assert np.all(np.isfinite(y)), f"non-finite outputs after a step of {h}: {dict(zip(ref.OUTPUTS, y))}"


@SETTINGS
@given(model=st.sampled_from(ref.MODEL_NAMES), params=valid_parameters(wide=False),
       vx=st.floats(-100.0, 100.0), H=log_uniform(1e-3, 10.0), k=st.integers(2, 50),
       u=st.tuples(values, values, values))
def test_chopping_does_not_matter(make_tire, model, params, vx, H, k, u):
    """One step of H equals k steps of H/k for inputs held constant."""
    one = make_tire(model, params=params, vx=vx)
    Y1 = one.run(np.array([u]), H)[-1]
    many = make_tire(model, params=params, vx=vx)
    Yk = many.run(np.tile(u, (k, 1)), H / k)[-1]
    Yref = ref.simulate(model, ref.parameters(**params), vx, np.array([u]), H)[-1]
    scale = np.abs(Yref) + np.max(np.abs(Yref[:4])) * 1e-6
    assert np.all(np.abs(Y1 - Yk) <= 1e-9 * scale + 1e-12), (Y1, Yk)


@SETTINGS
@given(model=st.sampled_from(ref.MODEL_NAMES), params=valid_parameters(wide=False),
       vx=st.one_of(st.just(0.0), st.floats(-100.0, 100.0)), h=log_uniform(1e-4, 2.0),
       seed=st.integers(0, 2**32 - 1), ramp=st.booleans())
def test_random_parameters_match_reference(make_tire, model, params, vx, h, seed, ramp):
    rng = np.random.default_rng(seed)
    n = 30
    U = rng.uniform(-1, 1, size=(n, 3))
    dU = rng.uniform(-1, 1, size=(n, 3)) if ramp else None
    tire = make_tire(model, params=params, vx=vx)
    Y = tire.run(U, h, dU=dU)
    Yref = ref.simulate(model, ref.parameters(**params), vx, U, h, dU=dU)
    assert_close_run(Y, Yref, label=f"{model} vx={vx} h={h}")
