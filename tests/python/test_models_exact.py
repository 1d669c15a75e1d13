"""All four models are exact for held and ramped inputs (docs/specification.md 4 and 6).

Every output after every step must equal the exact solution of the model's linear ODE
(reference.simulate: matrix exponential of the augmented system) to 1e-9 relative, i.e.
|y - yref| <= 1e-9 * max|yref| over the run + 1e-12.
"""

import numpy as np
import pytest

import reference as ref
from conftest import assert_close_run, random_steps, seed

SPEEDS = [0.0, 0.45, 1.6, 20.0, -5.0]
STEPS = {1e-3: 1500, 0.1: 200}
AMPLITUDES = [0.3, 0.2, 0.25]          # vy m/s, steerRate rad/s, vsx m/s


@pytest.mark.parametrize("h", list(STEPS))
@pytest.mark.parametrize("vx", SPEEDS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_piecewise_constant_inputs_are_exact(make_tire, model, vx, h):
    n = STEPS[h]
    rng = np.random.default_rng(seed(model, vx, h))
    U = random_steps(rng, n, hold=5, amplitudes=AMPLITUDES)
    tire = make_tire(model, vx=vx, vy=U[0, 0], steerRate=U[0, 1], vsx=U[0, 2])
    # outputs before the first step: states 0, so y = D u (direct feedthrough)
    _, _, _, D = ref.system(model, ref.parameters(), vx)
    y0 = tire.outputs()
    assert np.allclose(y0, D @ U[0], rtol=1e-12, atol=1e-12), f"initial outputs {y0} != D u {D @ U[0]}"
    Y = tire.run(U, h)
    Yref = ref.simulate(model, ref.parameters(), vx, U, h)
    assert_close_run(Y, Yref, label=f"{model} vx={vx} h={h}")


@pytest.mark.parametrize("vx", SPEEDS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_ramped_inputs_are_exact(make_tire, model, vx):
    """0.5 s steps with vy (and steerRate, vsx) ramping linearly over each step via
    fmi2SetRealInputDerivatives; a continuous piecewise-linear input."""
    h, n = 0.5, 40
    rng = np.random.default_rng(seed("ramp", model, vx))
    knots = rng.uniform(-1, 1, size=(n + 1, 3)) * np.array(AMPLITUDES)
    U = knots[:-1]
    dU = (knots[1:] - knots[:-1]) / h
    tire = make_tire(model, vx=vx)
    Y = tire.run(U, h, dU=dU)
    Yref = ref.simulate(model, ref.parameters(), vx, U, h, dU=dU)
    assert_close_run(Y, Yref, label=f"ramp {model} vx={vx}")


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_ramp_rate_is_kept_and_inputs_advance(make_tire, model):
    """After a ramped step the inputs sit at the ramp's end value and the rate persists
    until it is set again (set only once here, then rate 0 later)."""
    vx, h = 3.0, 0.2
    tire = make_tire(model, vx=vx, vy=0.1)
    tire.set_rates(vy=0.4, vsx=-0.3, steerRate=0.2)
    rt = ref.ReferenceTire(model, vx=vx, vy=0.1)
    rt.set_rates(vy=0.4, vsx=-0.3, steerRate=0.2)
    Y, Yr = [], []
    for k in range(12):
        if k == 8:
            tire.set_rates(vy=0.0, vsx=0.0, steerRate=0.0)
            rt.set_rates(vy=0.0, vsx=0.0, steerRate=0.0)
        tire.step(h)
        rt.step(h)
        Y.append(tire.outputs())
        Yr.append(rt.outputs())
    assert abs(rt.inputs["vy"] - (0.1 + 8 * h * 0.4)) < 1e-12
    assert_close_run(np.array(Y), np.array(Yr), label=f"kept rate {model}")


@pytest.mark.parametrize("vx", [100.0, -100.0, 0.0])
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_extreme_steps_are_exact(make_tire, model, vx):
    """docs/specification.md 6: any step from 1e-6 s to 10 s and |vx| up to 100 m/s."""
    rng = np.random.default_rng(seed("extreme", model, vx))
    hs = np.array([1e-6] * 20 + [10.0] * 3 + [1e-6] * 20 + [3.7e-3] * 20 + [10.0] * 2 + [1e-6] * 5)
    U = random_steps(rng, len(hs), hold=4, amplitudes=AMPLITUDES)
    tire = make_tire(model, vx=vx)
    Y = tire.run(U, hs)
    Yref = ref.simulate(model, ref.parameters(), vx, U, hs)
    assert_close_run(Y, Yref, label=f"extreme steps {model} vx={vx}")


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_result_does_not_depend_on_chopping(make_tire, model):
    """One 2 s step equals 2000 steps of 1 ms and 7 uneven steps (constant inputs)."""
    vx = 7.0
    u = np.array([0.2, 0.1, -0.15])
    results = []
    for hs in ([2.0], [1e-3] * 2000, [0.1, 0.5, 0.013, 0.387, 0.6, 0.25, 0.15]):
        tire = make_tire(model, vx=vx)
        Y = tire.run(np.tile(u, (len(hs), 1)), np.array(hs))
        results.append(Y[-1])
    scale = np.max(np.abs(results), axis=0)
    for r in results[1:]:
        assert np.all(np.abs(r - results[0]) <= 1e-9 * scale + 1e-12), f"{r} vs {results[0]}"


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_outputs_follow_the_latest_inputs(make_tire, model):
    """docs/specification.md 6: outputs match the current states and the most recently set inputs
    (direct feedthrough), also between steps and after changing vx."""
    rng = np.random.default_rng(seed("feedthrough", model))
    tire = make_tire(model, vx=4.0)
    rt = ref.ReferenceTire(model, vx=4.0)
    for k in range(20):
        vx = float(rng.choice([4.0, -4.0, 0.0, 11.0]))
        u = dict(zip(ref.DRIVING, rng.uniform(-0.5, 0.5, size=3)))
        tire.set(vx=vx, **u)
        rt.set(vx=vx, **u)
        y, yr = tire.outputs(), rt.outputs()
        assert np.all(np.abs(y - yr) <= 1e-9 * np.abs(yr) + 1e-9), (k, y, yr)
        tire.step(0.05)
        rt.step(0.05)


@pytest.mark.parametrize("h", [1e-3, 0.05])
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_speed_and_load_changing_every_step_are_exact(make_tire, model, h):
    """docs/specification.md 6b: in a vehicle model vx and Fz change every step. Each step is checked
    against the reference's own exact step at that step's vx (vx through zero and
    reverse, a sweep up to 30 m/s), with Fz varying and a lift-off in the middle."""
    n = 600
    rng = np.random.default_rng(seed("varying", model, h))
    t = np.arange(n) * h
    vx = np.concatenate([np.linspace(-3.0, 3.0, n // 3), 30.0 * np.sin(np.linspace(0, 3, n - n // 3))])
    vx += 1e-3 * rng.standard_normal(n)     # no two steps at the same speed
    Fz = 50000.0 * (1.0 + 0.2 * np.sin(7.0 * t))
    Fz[n // 2: n // 2 + 25] = 0.0
    U = random_steps(rng, n, hold=3, amplitudes=AMPLITUDES)
    tire = make_tire(model)
    Y = tire.run(U, h, vx=vx, Fz=Fz)
    Yref = ref.simulate(model, ref.parameters(), vx, U, h, Fz=Fz)
    assert_close_run(Y, Yref, label=f"varying vx, Fz {model} h={h}")
