"""Stop and go, reversing, and lift-off (docs/specification.md 4, 6 and 8).

vx goes 10 -> 0 -> -10 -> 0 -> 10 m/s with smooth (cosine) ramps while the wheel steers
and slides; vx is held over each step (a new value every step).
"""

import math

import numpy as np
import pytest

import reference as ref
from conftest import assert_close_run

T_END = 20.0
SEGMENTS = [(0.0, 10.0), (3.0, 10.0), (6.0, 0.0), (7.0, 0.0), (10.0, -10.0), (12.0, -10.0),
            (15.0, 0.0), (16.0, 0.0), (19.0, 10.0), (20.0, 10.0)]   # (time, vx) knots


def vx_profile(t):
    """Piecewise cosine blend between the knots: smooth (C1) speed profile."""
    t = np.asarray(t, float)
    out = np.empty_like(t)
    times = np.array([k[0] for k in SEGMENTS])
    vals = np.array([k[1] for k in SEGMENTS])
    i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    s = (t - times[i]) / (times[i + 1] - times[i])
    w = 0.5 - 0.5 * np.cos(math.pi * np.clip(s, 0.0, 1.0))
    out[:] = vals[i] + (vals[i + 1] - vals[i]) * w
    return out


def scenario(h, mirror=False):
    """Inputs held over steps of size h: (vx per step, U (N, 3))."""
    n = int(round(T_END / h))
    t = (np.arange(n) + 0.5) * h              # mid-step samples
    vx = vx_profile(t)
    vy = 0.15 * np.sin(math.tau * 0.7 * t) + 0.05
    r = 0.1 * np.cos(math.tau * 0.5 * t)
    vsx = 0.08 * np.sin(math.tau * 0.3 * t + 1.0)
    if mirror:
        vx, r = -vx, -r
    return vx, np.column_stack([vy, r, vsx])


def _run(make_tire, model, h, mirror=False):
    vx, U = scenario(h, mirror)
    tire = make_tire(model, vx=vx[0])
    return tire.run(U, h, vx=vx)


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_stop_and_go_is_exact(make_tire, model):
    """Through 0 and reverse: finite and equal to the exact solution step by step."""
    h = 0.01
    vx, U = scenario(h)
    Y = _run(make_tire, model, h)
    assert np.all(np.isfinite(Y))
    Yref = ref.simulate(model, ref.parameters(), vx, U, h)
    assert_close_run(Y, Yref, label=f"stop and go {model}")


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_stop_and_go_outputs_are_continuous(make_tire, model):
    """The largest step-to-step change of every output halves when the step halves:
    the outputs have no jumps (a jump would not shrink with the step)."""
    jumps = {}
    for h in (2e-3, 1e-3):
        Y = _run(make_tire, model, h)
        assert np.all(np.isfinite(Y)), f"{model} h={h}: non-finite outputs"
        jumps[h] = np.max(np.abs(np.diff(Y, axis=0)), axis=0)
        scale = np.max(np.abs(Y), axis=0)
    for j, name in enumerate(ref.OUTPUTS):
        if scale[j] == 0.0:
            assert name == "deflPsi" and model != "DDT"
            continue
        ratio = jumps[1e-3][j] / jumps[2e-3][j]
        assert 0.4 < ratio < 0.6, (
            f"{model} {name}: largest jump {jumps[1e-3][j]:.4g} at h=1ms vs {jumps[2e-3][j]:.4g} at h=2ms "
            f"(ratio {ratio:.3f}; a continuous output gives 0.5)")
        # and each jump is small against the output's range
        assert jumps[1e-3][j] < 0.02 * scale[j], f"{model} {name}: jump {jumps[1e-3][j]} vs range {scale[j]}"


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_reverse_driving_mirror(make_tire, model):
    """vx -> -vx (and, for DDT, steerRate -> -steerRate): rho = |vx| in every relaxation
    term, so the lateral and longitudinal responses are identical; DDT's yaw deflection and
    yaw moment flip sign (the steer path acts through vx uPsi)."""
    h = 2e-3
    Y = _run(make_tire, model, h)
    Ym = _run(make_tire, model, h, mirror=True)
    scale = np.max(np.abs(Y), axis=0) + 1e-300
    O = ref.OUT

    def same(name, a, b):
        err = np.max(np.abs(a - b)) / scale[O[name]]
        assert err <= 1e-12, f"{model} {name}: reversed run differs by {err:.3e} (relative)"

    for name in ("Fx", "Fy", "My", "alphaT", "kappaT", "deflX", "deflY"):
        same(name, Y[:, O[name]], Ym[:, O[name]])
    p = ref.parameters()
    if model == "DDT":
        same("deflPsi", Y[:, O["deflPsi"]], -Ym[:, O["deflPsi"]])
        yaw, yaw_m = (Z[:, O["Mz"]] + p["trail"] * Z[:, O["Fy"]] for Z in (Y, Ym))
        same("Mz", yaw, -yaw_m)
        assert np.max(np.abs(yaw)) > 0.0
    else:
        same("Mz", Y[:, O["Mz"]], Ym[:, O["Mz"]])
        assert np.all(Y[:, O["deflPsi"]] == 0.0) and np.all(Ym[:, O["deflPsi"]] == 0.0)


@pytest.mark.parametrize("model", ["RLT", "SecondOrder", "RingBody"])
def test_reverse_without_steering_flip(make_tire, model):
    """Models without a steering path: vx -> -vx alone (steerRate unchanged) gives
    identical outputs."""
    h = 5e-3
    vx, U = scenario(h)
    Y = make_tire(model, vx=vx[0]).run(U, h, vx=vx)
    Ym = make_tire(model, vx=-vx[0]).run(U, h, vx=-vx)
    scale = np.max(np.abs(Y), axis=0)
    assert np.all(np.abs(Y - Ym) <= 1e-12 * scale)


@pytest.mark.parametrize("Fz_off", [0.0, -2000.0])
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_lift_off(make_tire, model, Fz_off):
    """Fz <= 0: Fx, Fy, Mz, My are zero at once and stay zero whatever the inputs; the
    deflections relax as exp(-t/0.01 s); Fz > 0 again resumes the model from there."""
    vx, h = 6.0, 0.005
    rng = np.random.default_rng(7)
    tire = make_tire(model, vx=vx)
    rt = ref.ReferenceTire(model, vx=vx)
    n1, n2, n3 = 200, 20, 200
    U = rng.uniform(-1, 1, size=(n1 + n2 + n3, 3)) * np.array([0.2, 0.2, 0.1])
    U = np.repeat(U[::10], 10, axis=0)
    Fz = np.concatenate([np.full(n1, 40000.0), np.full(n2, Fz_off), np.full(n3, 60000.0)])
    # loaded
    Y1 = tire.run(U[:n1], h, Fz=Fz[:n1])
    before = tire.outputs()
    assert np.max(np.abs(before[:4])) > 0.0
    # lift off: the loads vanish as soon as Fz is set
    tire.set(Fz=Fz_off)
    now = tire.outputs()
    for name in ref.LOADS:
        assert now[ref.OUT[name]] == 0.0, f"{name} = {now[ref.OUT[name]]} right after lift-off"
    for name in ("deflX", "deflY", "deflPsi"):
        assert now[ref.OUT[name]] == before[ref.OUT[name]], f"{name} jumped at lift-off"
    # The transient slips divide by the loaded relaxation lengths (docs/specification.md 4b); off the
    # ground there is no load, and they use the nominal lengths.
    p = ref.parameters()
    for slip, deflection, length in (("alphaT", "deflY", "sigmaY"), ("kappaT", "deflX", "sigmaX")):
        expected_slip = -now[ref.OUT[deflection]] / p[length]
        assert abs(now[ref.OUT[slip]] - expected_slip) <= 1e-12 * abs(expected_slip), slip
    Y2 = tire.run(U[n1:n1 + n2], h, Fz=Fz[n1:n1 + n2])
    assert np.all(np.isfinite(Y2))
    for name in ref.LOADS:
        assert np.all(Y2[:, ref.OUT[name]] == 0.0), f"{name} not zero while lifted off"
    t = (np.arange(n2) + 1) * h
    for name in ("deflX", "deflY", "deflPsi", "alphaT", "kappaT"):
        j = ref.OUT[name]
        expected = now[j] * np.exp(-t / ref.LIFT_OFF_TIME_CONSTANT)
        assert np.all(np.abs(Y2[:, j] - expected) <= 1e-9 * abs(now[j]) + 1e-15), (
            f"{name} does not relax with 0.01 s: {Y2[:5, j]} vs {expected[:5]}")
    # touch down again
    Y3 = tire.run(U[n1 + n2:], h, Fz=Fz[n1 + n2:])
    assert np.max(np.abs(Y3[-50:, ref.OUT["Fy"]])) > 100.0
    Yref = rt.run(U, h, Fz=Fz)
    assert_close_run(np.vstack([Y1, Y2, Y3]), Yref, label=f"lift-off {model}")
