"""Friction limit: stick and slide (docs/specification.md 4c, the friction lines of 5, and 6).

Against the FMU (all with the friction law set through the `friction` selector):

a. Unlimited is the linear model of docs/specification.md 4/4b (reference.simulate, 1e-9), however large the slip.
b. Coulomb saturates exactly: steady Fy = sign(alpha) min(Calpha(Fz)|alpha|, muY(Fz) Fz) and
   Fx = sign(kappa) min(Ckappa(Fz)|kappa|, muX(Fz) Fz) to 1e-9, at 0.5, 1 and 1.5 Fz0.
c. Brush steady state: within 2 % of Fmax of the brush curve, equal (1e-9) to the four-branch
   curve sum_i min(w_i x, phi_i), and exactly linear (1e-9) below 0.2 Fmax.
d. Standstill push, plateau and reversal (Coulomb): the elastic-perfectly-plastic curve with
   stiffness C_y, exact for RLT, within 0.5 % of Fmax for the damped models; any step size.
e. A parked wheel mass under 0.5 Fmax with a 20 % ripple does not creep.
f. The friction ellipse is never exceeded in combined slip; a closed cycle absorbs energy.
g. DDT steered +-40 deg at 0.2 Hz at standstill: 31.4 kN.m unlimited, boreRadius muY Fz with
   friction.
h. Step-size independence with stick/slip events: one 0.25 s step = 250 steps of 1 ms (1e-6
   Fmax); and on a random history (inputs and vx jumping every 30 ms), 10 ms steps = 100 steps
   of 0.1 ms, which catches slides that start and end inside one step.
i. The FMU equals the independent reference friction_reference.py (1e-7 of Fmax), per model
   and law at constant load, and with Brush at a load that changes every step.

Reference-only tests (named test_reference_*; they need no FMU) check friction_reference.py
itself: Unlimited = reference.simulate, the elastic-plastic standstill push in closed form,
its own step-size independence and that its branch forces never leave their ellipses, and
the projection of the damped groups.

The FMU tests fail (pytest.fail, not skip) if the FMU declares no `friction` variable.
"""

import math

import numpy as np
import pytest

import friction_reference as fr
import harness
import reference as ref
from conftest import Tire, assert_close_run, has_friction, random_steps, seed

LAWS = ["Coulomb", "Brush"]
P = fr.parameters()
FZ0 = P["Fz0"]
C_Y = P["Calpha"] / P["sigmaY"]
FY, FX, MZ, MY = (ref.OUT[n] for n in ("Fy", "Fx", "Mz", "My"))
# non-default friction parameters (tests h and i): a non-circular ellipse, another load law
FRICTION_PARAMS = {"muX": 0.9, "muY": 0.75, "muLoadSensitivity": -0.15, "boreRadius": 0.12}


# --------------------------------------------------------------------------- FMU access

@pytest.fixture
def make_friction_tire(model_description, unzipdir):
    """make_friction_tire(model, friction, params=None, vx=..., Fz=...) -> conftest.Tire
    with that friction law and parameters (friction ones included)."""
    if not has_friction(model_description):
        pytest.fail("the FMU declares no `friction` variable (docs/specification.md 4c): rebuild it")
    tires = []

    def factory(model, friction, params=None, **inputs):
        tire = Tire(model_description, unzipdir, model=model, params=params,
                    name=f"friction{len(tires)}", friction=friction, **inputs)
        tires.append(tire)
        return tire

    yield factory
    for tire in tires:
        tire.close()


def hold(tire, seconds, h=1.0, vy=0.0, steerRate=0.0, vsx=0.0):
    """Hold the driving inputs for `seconds` in steps of h; returns the outputs (N, 9)."""
    n = int(round(seconds / h))
    return tire.run(np.tile([vy, steerRate, vsx], (n, 1)), h)


# --------------------------------------------------------------------------- a. Unlimited

@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_unlimited_is_the_linear_model(make_friction_tire, model):
    """Slips far beyond any friction limit, Fz = Fz0: exactly reference.simulate (1e-9)."""
    rng = np.random.default_rng(seed("unlimited", model))
    n, h, vx = 300, 0.01, 4.0
    U = random_steps(rng, n, hold=10, amplitudes=[2.0, 0.5, 2.0])
    tire = make_friction_tire(model, "Unlimited", vx=vx)
    Y = tire.run(U, h)
    assert_close_run(Y, ref.simulate(model, ref.parameters(), vx, U, h), label=f"Unlimited {model}")
    assert np.abs(Y[:, FY]).max() > 2.0 * fr.limits(P, FZ0)["y"], "the run should exceed the limit"


def test_friction_variables_are_declared(model_description):
    """docs/specification.md 3: `friction` Integer VR 121, start 3 (Brush), fixed parameter; muX, muY (0.8),
    muLoadSensitivity (-0.1), boreRadius (0.1 m) are Real parameters VR 122..125."""
    variables = {v.name: v for v in model_description.modelVariables}
    assert "friction" in variables, "the FMU declares no `friction` variable"
    f = variables["friction"]
    assert (f.valueReference, f.causality, f.variability) == (fr.FRICTION_VR, "parameter", "fixed")
    assert f.type in ("Integer", "Enumeration") and int(f.start) == fr.FRICTION_LAWS["Brush"]
    for name, vr in fr.FRICTION_PARAMETER_VR.items():
        v = variables[name]
        assert (v.valueReference, v.type, v.causality) == (vr, "Real", "parameter"), name
        assert float(v.start) == fr.FRICTION_DEFAULTS[name], (name, v.start)


def test_conftest_tire_defaults_to_unlimited(make_tire):
    """conftest.Tire sets friction = Unlimited unless told otherwise, so the linear tests
    stay linear: a slip of 0.3 gives Calpha 0.3 (3.5 Fmax), not Fmax."""
    tire = make_tire("RLT", vx=10.0)
    fy = hold(tire, 20.0, vy=-3.0)[-1][FY]
    assert abs(fy - P["Calpha"] * 0.3) <= 1e-9 * P["Calpha"] * 0.3, fy
    tire = make_tire("RLT", vx=10.0, friction="Coulomb")
    fy = hold(tire, 20.0, vy=-3.0)[-1][FY]
    assert abs(fy - fr.limits(P, FZ0)["y"]) <= 1e-9 * fr.limits(P, FZ0)["y"], fy


# --------------------------------------------------------------------------- b. Coulomb

@pytest.mark.parametrize("ratio", [0.5, 1.0, 1.5])
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_coulomb_saturates_at_the_load_dependent_limit(make_friction_tire, model, ratio):
    """Steady rolling at vx = 10 m/s, 20 s in 1 s steps, one slip at a time:
    slip 0.3 (far past the limit, both signs) and 0.005 (linear), laterally and
    longitudinally: F = sign(s) min(C(Fz)|s|, mu(Fz) Fz) to 1e-9 relative; the other force 0."""
    Fz = ratio * FZ0
    lim = fr.limits(P, Fz)
    vx = 10.0
    stiffness = {"y": ref.cornering_stiffness_at(P, Fz), "x": P["Ckappa"] * ratio}
    for direction, col, other in (("y", FY, FX), ("x", FX, FY)):
        for slip in (0.3, -0.3, 0.005):
            tire = make_friction_tire(model, "Coulomb", vx=vx, Fz=Fz)
            drive = {"vy": -slip * vx} if direction == "y" else {"vsx": -slip * vx}
            y = hold(tire, 20.0, **drive)[-1]
            expected = math.copysign(min(stiffness[direction] * abs(slip), lim[direction]), slip)
            assert abs(y[col] - expected) <= 1e-9 * abs(expected), (
                f"{model} Fz={Fz} {direction} slip {slip}: {y[col]!r} != {expected!r}")
            assert abs(y[other]) <= 1e-9 * lim[direction], y


# --------------------------------------------------------------------------- c. Brush

X_SWEEP = [0.05, 0.1, 0.15, 0.199, 0.3, 0.5, 0.8, 1.2, 1.6, 2.0, 2.5, 3.0, 4.0]


@pytest.mark.parametrize("direction", ["y", "x"])
@pytest.mark.parametrize("ratio", [0.5, 1.0])
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_brush_steady_state_follows_the_brush_curve(make_friction_tire, model, ratio, direction):
    """Sweep x = C(Fz)|slip|/Fmax over 0.05..4 with alternating signs at vx = 10 m/s (20 s per
    point): F/Fmax within 0.02 of 3t - 3t^2 + t^3 (t = min(1, x/3)), equal to the four-branch
    curve sum_i min(w_i x, phi_i) to 1e-9, and F = C(Fz) slip to 1e-9 for x < 0.2."""
    Fz = ratio * FZ0
    Fmax = fr.limits(P, Fz)[direction]
    C = ref.cornering_stiffness_at(P, Fz) if direction == "y" else P["Ckappa"] * ratio
    col = FY if direction == "y" else FX
    vx = 10.0
    tire = make_friction_tire(model, "Brush", vx=vx, Fz=Fz)
    for k, x in enumerate(X_SWEEP):
        x = x if k % 2 == 0 else -x
        slip = x * Fmax / C
        drive = {"vy": -slip * vx} if direction == "y" else {"vsx": -slip * vx}
        F = hold(tire, 20.0, **drive)[-1][col]
        label = f"{model} Fz={Fz} {direction} x={x}: F/Fmax = {F / Fmax!r}"
        assert abs(F / Fmax - fr.brush_curve(x)) <= 0.02, label
        assert abs(F / Fmax - fr.steady_force_fraction(x)) <= 1e-9, label
        if abs(x) < 0.2:
            assert abs(F - C * slip) <= 1e-9 * abs(C * slip), label


# --------------------------------------------------------------------------- d. standstill push

def elastic_plastic_force(t, v, t_rev, stiffness, Fmax):
    """Element force of a spring stiffness in series with a Coulomb slider (limit Fmax) whose
    end moves at +v until t_rev and at -v after (closed form)."""
    t = np.asarray(t, float)
    up = np.minimum(stiffness * v * np.minimum(t, t_rev), Fmax)
    at_rev = min(stiffness * v * t_rev, Fmax)
    down = np.maximum(at_rev - stiffness * v * (t - t_rev), -Fmax)
    return np.where(t <= t_rev, up, down)


@pytest.mark.parametrize("h", [0.001, 0.007, 0.25])
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_standstill_push_plateau_and_reversal(make_friction_tire, model, h):
    """vx = 0, Coulomb: vy = +0.01 m/s for 14 s (elastic to Fmax at 11.4 s, then a plateau),
    then -0.01 m/s to 40 s (the force swings to +Fmax over 2 Fmax/C_y = 0.229 m of travel).
    Fy = -(elastic-plastic curve): RLT to 1e-9 Fmax; damped models (a damper or contact mass
    in the path) within 0.5 % of Fmax, and on the plateaus (1 s after reaching them) exactly
    at the limit (1e-9)."""
    v, t_rev, t_end = 0.01, 14.0, 40.0
    Fmax = fr.limits(P, FZ0)["y"]
    n_rev, n = int(round(t_rev / h)), int(t_end / h + 1e-9)
    U = np.zeros((n, 3))
    U[:n_rev, 0], U[n_rev:, 0] = v, -v
    tire = make_friction_tire(model, "Coulomb", vx=0.0)
    Fy = tire.run(U, h)[:, FY]
    t = (np.arange(n) + 1) * h
    ideal = -elastic_plastic_force(t, v, n_rev * h, C_Y, Fmax)
    err = np.abs(Fy - ideal)
    tol = 1e-9 if model == "RLT" else 5e-3
    k = int(np.argmax(err))
    assert err[k] <= tol * Fmax, f"{model} h={h}: |Fy - ideal| = {err[k]:.6g} N at t = {t[k]:.4g} s"
    t_plateau_1 = Fmax / (C_Y * v)                 # reaches -Fmax
    t_plateau_2 = n_rev * h + 2.0 * Fmax / (C_Y * v)   # reaches +Fmax after 2 Fmax/C_y of travel
    on = ((t >= t_plateau_1 + 1.0) & (t <= n_rev * h)) | (t >= t_plateau_2 + 1.0)
    assert on.sum() > 10
    assert np.all(np.abs(np.abs(Fy[on]) - Fmax) <= 1e-9 * Fmax), np.abs(np.abs(Fy[on]) - Fmax).max()


# --------------------------------------------------------------------------- e. parked mass

def park(tire, Fmax):
    """Push the wheel (vx = 0) sideways at 0.02 m/s until its tire carries 0.65 Fmax, back
    off by 0.15 Fmax of elastic travel (stiffness C_y: every branch sticks when unloading),
    settle 2 s: a wheel parked under about 0.5 Fmax whose branches all stick with margin on
    both sides (the state a parked car settles to). Returns the parked load -Fy."""
    v = 0.02
    while -tire.outputs()[FY] < 0.65 * Fmax:
        hold(tire, 0.01, h=0.001, vy=v)
    hold(tire, 0.15 * Fmax / C_Y / v, h=0.001, vy=-v)
    hold(tire, 2.0, h=2.0)
    return -tire.outputs()[FY]


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_parked_mass_does_not_drift(make_friction_tire, model, law):
    """A wheel mass m coupled laterally (harness.wheel_cosim: 1 ms steps, symplectic Euler),
    parked as in park(), loaded by F(t) = F0 (1 + 0.2 sin(2 pi 10 t)) for 4 s, F0 = the parked
    tire force (0.5 Fmax; the dampers shift it by < 0.01 Fmax). y = wheel position relative
    to where it was parked.

    m = C_y/(8 pi)^2 = 554 kg (about the 500 kg of the brief) makes the undamped RLT's free
    period 0.25 s, so a 1 s window holds exactly 10 ripple periods and (to (omega h)^2/24 =
    3e-5) 4 free periods: the window mean of any oscillation is ~1e-4 of its amplitude
    (amplitude ~ 7 mm -> ~5 nm here).
    * Damped models (DDT, SecondOrder, RingBody): the drift, |mean y over the last second|,
      is below 10 um, and the creep rate |mean[3,4] - mean[2,3]| below 1 um per second.
    * RLT (undamped, oscillates for ever): nothing slides (Fy = F_parked - C_y y to 1e-9
      Fmax: the motion is the linear spring-mass one), and the mean position over the last
      second equals the mean over the first to 0.1 um (20 times the 5 nm expected above,
      1 % of the damped models' allowance)."""
    Fmax = fr.limits(P, FZ0)["y"]
    tire = make_friction_tire(model, law, vx=0.0)
    F0 = park(tire, Fmax)
    assert abs(F0 / Fmax - 0.5) < 0.01, F0 / Fmax
    m = C_Y / (8.0 * math.pi) ** 2
    h, n = 1e-3, 4000
    t = np.arange(n) * h
    F_ext = F0 * (1.0 + 0.2 * np.sin(math.tau * 10.0 * t))
    _, v, Fy = harness.wheel_cosim(tire, m, 0.0, h, n, F_ext)
    y = np.concatenate([[0.0], np.cumsum(v[:-1] * h)])   # position at t_k (vy held over steps)
    means = [y[k * 1000:(k + 1) * 1000].mean() for k in range(4)]
    label = f"{model} {law}: window means {np.array(means) * 1e6} um"
    if model == "RLT":
        assert np.max(np.abs(Fy - (-F0 - C_Y * y))) <= 1e-9 * Fmax, label
        assert abs(means[3] - means[0]) <= 1e-7, label
    else:
        assert abs(means[3]) <= 10e-6, label
        assert abs(means[3] - means[2]) <= 1e-6, label


# --------------------------------------------------------------------------- f. ellipse, energy

@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_friction_ellipse_is_never_exceeded(make_friction_tire, model, law):
    """vx = 5, combined slip: vy, vsx up to +-3 m/s (slips up to 0.6) and steerRate up to
    +-0.5 rad/s, first new random values every 0.1 s (300 steps of 10 ms), then eight 3 s
    holds. (Fx/Fmax_x)^2 + (Fy/Fmax_y)^2 <= 1 + 1e-9:
    * RLT and DDT: at every step (their hub forces are the element forces);
    * SecondOrder and RingBody: at the end of every 3 s hold. Their hub Fy is the carcass
      force, which differs from the limited tread force by the contact mass's inertia
      force, so it may leave the ellipse in transients (test_matches_the_reference holds
      their tread forces to the reference, whose branch forces never leave the ellipse)."""
    lim = fr.limits(P, FZ0)
    rng = np.random.default_rng(seed("ellipse", model, law))
    fast = random_steps(rng, 300, hold=10, amplitudes=[3.0, 0.5, 3.0])
    slow = random_steps(rng, 8 * 300, hold=300, amplitudes=[3.0, 0.5, 3.0])
    tire = make_friction_tire(model, law, vx=5.0)
    Y = tire.run(np.vstack([fast, slow]), 0.01)
    f = (Y[:, FX] / lim["x"]) ** 2 + (Y[:, FY] / lim["y"]) ** 2
    if model in ("RLT", "DDT"):
        checked = f
    else:
        checked = f[300 + 299::300]
        assert len(checked) == 8
    assert checked.max() <= 1.0 + 1e-9, f"{model} {law}: max ellipse value {checked.max()!r}"
    assert checked.max() >= 0.999, "the run should reach the limit"


@pytest.mark.parametrize("radius", [0.02, 0.2])
@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_closed_cycle_absorbs_energy(make_friction_tire, model, law, radius):
    """vx = 0, the wheel moves on a circle of radius R (vy = V cos(W t), vsx = V sin(W t),
    V = R W, period 1 s), inputs ramped linearly between 1 ms samples (input derivatives), so
    the FMU's outputs at the sample times are exact. After two cycles (periodic steady state)
    the energy the tire absorbs over the third, E = -integral (Fx vsx + Fy vy) dt, by the
    trapezoidal rule on the 1000 samples, is >= 0 within its quadrature error
    (estimated as |E_h - E_2h|, E_2h from every other sample). R = 0.2 m slides all round
    (E must be clearly positive); R = 0.02 m is elastic for Coulomb RLT (E = 0, roundoff)."""
    period, n_per, cycles = 1.0, 1000, 3
    h = period / n_per
    W = math.tau / period
    V = radius * W
    t = np.arange(cycles * n_per + 1) * h
    u = np.column_stack([V * np.cos(W * t), 0.0 * t, V * np.sin(W * t)])
    tire = make_friction_tire(model, law, vx=0.0)
    Y = tire.run(u[:-1], h, dU=np.diff(u, axis=0) / h)
    power = np.concatenate([[0.0], Y[:, FX] * u[1:, 2] + Y[:, FY] * u[1:, 0]])
    last = power[(cycles - 1) * n_per:]
    E_h = -np.trapezoid(last, dx=h)
    E_2h = -np.trapezoid(last[::2], dx=2 * h)
    err = abs(E_h - E_2h) + 1e-12 * fr.limits(P, FZ0)["y"] * radius
    label = f"{model} {law} R={radius}: E = {E_h!r} J (E_2h {E_2h!r})"
    assert E_h >= -err, label
    if radius == 0.2:
        assert E_h >= 0.5 * fr.limits(P, FZ0)["y"] * radius and E_h > 100 * err, label


# --------------------------------------------------------------------------- g. DDT yaw

@pytest.mark.parametrize("ratio", [1.0, 1.5])
@pytest.mark.parametrize("law", ["Unlimited", "Coulomb", "Brush"])
def test_ddt_standstill_steering_moment(make_friction_tire, law, ratio):
    """Wheel-loader snake steering (docs/specification.md 9): DDT at vx = 0, steer angle 40 deg sin(2 pi 0.2 t)
    (steerRate its derivative, ramped between 1 ms samples), stiffnessPsi 45000,
    dampingPsi 400, two periods. vy = vx = 0, so Fy = 0 and the trail adds nothing:
    Unlimited: max |Mz| = 40 deg sqrt(K^2 + (D omega)^2) ~ 45000 * 0.698 = 31.4 kN.m (1 %);
    Coulomb and Brush: max |Mz| = boreRadius muY(Fz) Fz to 1e-6, never above it."""
    params = {"stiffnessPsi": 45000.0, "dampingPsi": 400.0}
    Fz = ratio * FZ0
    amp, freq = math.radians(40.0), 0.2
    omega = math.tau * freq
    h, n = 1e-3, int(round(2.0 / freq / 1e-3))
    t = np.arange(n + 1) * h
    r = amp * omega * np.cos(omega * t)
    u = np.column_stack([0.0 * t, r, 0.0 * t])
    tire = make_friction_tire("DDT", law, params=params, vx=0.0, Fz=Fz)
    Y = tire.run(u[:-1], h, dU=np.diff(u, axis=0) / h)
    Mz = np.abs(Y[:, MZ])
    assert np.abs(Y[:, FY]).max() <= 1e-9, np.abs(Y[:, FY]).max()
    if law == "Unlimited":
        assert abs(Mz.max() / 31.4e3 - 1.0) <= 0.01, Mz.max()
        exact = amp * math.hypot(45000.0, 400.0 * omega)
        assert abs(Mz.max() / exact - 1.0) <= 1e-3, (Mz.max(), exact)
    else:
        M_max = fr.limits(fr.parameters(**params), Fz)["psi"]
        assert abs(Mz.max() / M_max - 1.0) <= 1e-6, (Mz.max(), M_max)
        assert Mz.max() <= M_max * (1.0 + 1e-12), (Mz.max(), M_max)


# --------------------------------------------------------------------------- h. step size

# (vx, vy, steerRate, vsx), each held for 0.25 s: combined sliding, reversals, standstill,
# reverse driving, a relaxation back into sticking
HISTORY = [(5.0, -1.5, 0.0, 0.8), (5.0, 1.0, 0.6, -0.5), (0.0, 0.8, -0.8, 0.3),
           (2.0, -0.6, 0.4, -0.3), (0.0, -0.6, 0.8, 0.4), (-3.0, 0.9, -0.4, 0.4),
           (5.0, 0.05, 0.0, -0.05), (1.0, -0.8, -0.3, 0.6)]
INTERVAL = 0.25


def load_scales(p, Fz):
    """Per-load scale for 'within 1e-6 Fmax': Fx, Fy by their limits, Mz by the yaw limit
    plus trail Fmax_y, My by Re Fmax_x."""
    lim = fr.limits(p, Fz)
    return np.array([lim["x"], lim["y"], lim["psi"] + p["trail"] * lim["y"], p["Re"] * lim["x"]])


@pytest.mark.parametrize("h", [1.0, 5.0])
@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_long_sticking_steps_stay_exact(make_friction_tire, model, law, h):
    """Every element sticking (3 % of Fmax at 1.5 Fz0) with steps of 1 and 5 s, long
    against the tire's time constants: the forces are the linear steady state
    Calpha(Fz) alpha to 1e-9 at every step (docs/specification.md 6), as with the Unlimited law."""
    Fz, vx = 1.5 * FZ0, 10.0
    p = ref.parameters()
    alpha = 0.03 * fr.limits(fr.parameters(), Fz)["y"] / ref.cornering_stiffness_at(p, Fz)
    tire = make_friction_tire(model, law, vx=vx, vy=-vx * alpha, Fz=Fz)
    expected = ref.cornering_stiffness_at(p, Fz) * alpha
    for k in range(int(40.0 / h)):
        tire.step(h)
        if k * h >= 10.0:
            Fy = tire.get("Fy")[0]
            assert abs(Fy / expected - 1.0) <= 1e-9, (k, h, Fy, expected)


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_step_size_independence_with_events(make_friction_tire, model, law):
    """HISTORY (stick/slip events inside the intervals: test_reference_history_has_events)
    once in 0.25 s steps and once in 1 ms steps: Fx, Fy, Mz, My at the end of every interval
    agree within 1e-6 of their friction scale (load_scales)."""
    coarse = make_friction_tire(model, law)
    fine = make_friction_tire(model, law)
    scale = load_scales(P, FZ0)
    loads = [ref.OUT[n] for n in ref.LOADS]
    for k, (vx, vy, r, vsx) in enumerate(HISTORY):
        coarse.set(vx=vx)
        fine.set(vx=vx)
        a = coarse.run(np.array([[vy, r, vsx]]), INTERVAL)[-1]
        n_fine = int(round(INTERVAL / 1e-3))
        b = fine.run(np.tile([vy, r, vsx], (n_fine, 1)), 1e-3)[-1]
        err = np.abs(a[loads] - b[loads]) / scale
        assert np.all(err <= 1e-6), f"{model} {law} interval {k}: errors / scale {err}"


def random_history(key, n=500, hold=3):
    """Random inputs held for `hold` steps: vx in [-6, 6] m/s (standstill crossings and
    reverse included), vy and vsx up to +-1.5 m/s, steerRate up to +-0.8 rad/s."""
    rng = np.random.default_rng(seed("history", *key))
    U = random_steps(rng, n, hold, [1.5, 0.8, 1.5])
    vx = random_steps(rng, n, hold, [6.0])[:, 0]
    return vx, U


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_step_size_independence_random_history(make_friction_tire, model, law):
    """random_history (500 steps of 10 ms; inputs jump every 30 ms, vx included) with the
    friction parameters of test_matches_the_reference, in 10 ms steps and in 0.1 ms steps
    (100 per 10 ms, same held inputs): Fx, Fy, Mz, My agree at every 10 ms within 1e-6 of
    their friction scale (docs/specification.md 6). Catches slides that start and end inside one step
    (a sticking element whose force touches the limit only briefly after an input jump),
    which a check of the limit at the step's end alone would miss."""
    vx, U = random_history((model, law))
    h, n = 0.01, 100
    Fz = 0.8 * FZ0
    coarse = make_friction_tire(model, law, params=FRICTION_PARAMS, vx=vx[0], Fz=Fz)
    fine = make_friction_tire(model, law, params=FRICTION_PARAMS, vx=vx[0], Fz=Fz)
    loads = [ref.OUT[name] for name in ref.LOADS]
    a = coarse.run(U, h, vx=vx)[:, loads]
    b = fine.run(np.repeat(U, n, axis=0), h / n, vx=np.repeat(vx, n))[n - 1::n, loads]
    err = np.max(np.abs(a - b) / load_scales(fr.parameters(**FRICTION_PARAMS), Fz), axis=1)
    k = int(np.argmax(err > 1e-6)) if np.any(err > 1e-6) else None
    assert k is None, (f"{model} {law}: 10 ms steps differ from 0.1 ms steps by {err[k]:.3g} of "
                       f"Fmax first at step {k} (t = {k * h:.2f}..{(k + 1) * h:.2f} s; worst "
                       f"{err.max():.3g}): vx {vx[k]:.4g}, [vy, steerRate, vsx] {U[k]}")


# --------------------------------------------------------------------------- i. reference

def reference_scenario(n=300, h=0.01):
    """vx = 4 cos(2 pi 0.2 t) (through standstill into reverse), reversing vy, steerRate
    and vsx large enough to slide; all held over steps (mid-step samples)."""
    t = (np.arange(n) + 0.5) * h
    vx = 4.0 * np.cos(math.tau * 0.2 * t)
    U = np.column_stack([1.0 * np.sin(math.tau * 0.9 * t) + 0.2,
                         0.8 * np.cos(math.tau * 0.6 * t),
                         0.8 * np.sin(math.tau * 0.7 * t + 1.0)])
    return vx, U, h


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_matches_the_reference(make_friction_tire, model, law):
    """reference_scenario at Fz = 0.8 Fz0 with muX 0.9, muY 0.75 (non-circular ellipse, so
    DDT's combined sliding is not radial), muLoadSensitivity -0.15, boreRadius 0.12: every
    output equals friction_reference.simulate to 1e-7 of its largest value (for the loads
    that is about Fmax)."""
    vx, U, h = reference_scenario()
    Fz = 0.8 * FZ0
    tire = make_friction_tire(model, law, params=FRICTION_PARAMS, vx=vx[0], Fz=Fz)
    Y = tire.run(U, h, vx=vx)
    Yref = fr.simulate(model, law, FRICTION_PARAMS, vx, U, h, Fz=Fz)
    assert_close_run(Y, Yref, rtol=1e-7, atol=1e-12, label=f"{model} {law}")


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_matches_the_reference_with_a_varying_load(make_friction_tire, model):
    """Brush, the first 120 steps of reference_scenario with Fz = Fz0 (0.9 + 0.3 sin(2 pi 1.3 t))
    held over each step: the limits and lengths change every step, and elements outside
    their shrinking limit are put on it (docs/specification.md 4c); every output equals the reference to 1e-7."""
    vx, U, h = reference_scenario(120)
    t = (np.arange(120) + 0.5) * h
    Fz = FZ0 * (0.9 + 0.3 * np.sin(math.tau * 1.3 * t))
    tire = make_friction_tire(model, "Brush", params=FRICTION_PARAMS, vx=vx[0], Fz=Fz[0])
    Y = tire.run(U, h, vx=vx, Fz=Fz)
    Yref = fr.simulate(model, "Brush", FRICTION_PARAMS, vx, U, h, Fz=Fz)
    assert_close_run(Y, Yref, rtol=1e-7, atol=1e-12, label=f"{model} Brush, varying Fz")


# --------------------------------------------------------------------------- reference checks

@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_reference_unlimited_is_the_linear_reference(model):
    """friction_reference with Unlimited equals reference.simulate (1e-9) at a load other
    than Fz0 (so the load-scaled lengths are the same in both)."""
    rng = np.random.default_rng(seed("reference unlimited", model))
    n, h, vx, Fz = 100, 0.01, 3.0, 0.7 * FZ0
    U = random_steps(rng, n, hold=10, amplitudes=[0.5, 0.3, 0.4])
    Y = fr.simulate(model, "Unlimited", None, vx, U, h, Fz=Fz)
    assert_close_run(Y, ref.simulate(model, ref.parameters(), vx, U, h, Fz=np.full(n, Fz)),
                     label=f"reference Unlimited {model}")


@pytest.mark.parametrize("h", [0.03, 0.25])
def test_reference_standstill_push_is_elastic_plastic(h):
    """The reference's RLT (Coulomb, vx = 0) pushed as in test d is the closed-form
    elastic-plastic curve to 1e-9 Fmax (events located exactly)."""
    v, t_rev, t_end = 0.01, 14.0, 40.0
    Fmax = fr.limits(P, FZ0)["y"]
    n_rev, n = int(round(t_rev / h)), int(t_end / h + 1e-9)
    U = np.zeros((n, 3))
    U[:n_rev, 0], U[n_rev:, 0] = v, -v
    Fy = fr.simulate("RLT", "Coulomb", None, 0.0, U, h)[:, FY]
    t = (np.arange(n) + 1) * h
    err = np.abs(Fy + elastic_plastic_force(t, v, n_rev * h, C_Y, Fmax))
    assert err.max() <= 1e-9 * Fmax, err.max()


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_reference_history_has_events(model, law):
    """HISTORY in the reference, one 0.25 s step per interval: stick/slip switches happen
    inside the steps and the branch forces end inside their ellipses (1e-12). Brush (the
    most switches): the loads equal those of five 0.05 s steps per interval within 1e-9 of
    their scale (the reference's own step-size independence)."""
    coarse = fr.FrictionReferenceTire(model, law)
    fine = fr.FrictionReferenceTire(model, law) if law == "Brush" else None
    scale = load_scales(P, FZ0)
    loads = [ref.OUT[n] for n in ref.LOADS]
    for k, (vx, vy, r, vsx) in enumerate(HISTORY):
        coarse.set(vx=vx, vy=vy, steerRate=r, vsx=vsx)
        coarse.step(INTERVAL)
        assert coarse.ellipse_values().max() <= 1.0 + 1e-12
        if fine is not None:
            fine.set(vx=vx, vy=vy, steerRate=r, vsx=vsx)
            for _ in range(5):
                fine.step(INTERVAL / 5)
                assert fine.ellipse_values().max() <= 1.0 + 1e-12
            err = np.abs(coarse.outputs()[loads] - fine.outputs()[loads]) / scale
            assert np.all(err <= 1e-9), f"interval {k}: {err}"
    assert coarse.n_events >= 6, coarse.n_events


def test_reference_damped_projection():
    """damped_group_forces: outside the ellipse the force lands on it (1e-14), along
    T_k/(1 + lam a_k) with one lam >= 0 for both directions; inside it is T."""
    rng = np.random.default_rng(7)
    Ly, Lx = 1.3, 0.7
    Ty, Tx = rng.uniform(-1.5, 1.5, size=(2, 1000)) * np.array([[Ly], [Lx]])
    dy, dx = 2.0, 0.5
    Fy, Fx = fr.damped_group_forces(Ty, Tx, Ly, Lx, dy, dx)
    f_trial = fr.ellipse_value(Ty, Tx, Ly, Lx)
    out = f_trial > 1.0
    assert out.sum() > 100 and (~out).sum() > 100
    assert np.all(Fy[~out] == Ty[~out]) and np.all(Fx[~out] == Tx[~out])
    assert np.max(np.abs(fr.ellipse_value(Fy[out], Fx[out], Ly, Lx) - 1.0)) <= 1e-14
    lam_y = (Ty[out] / Fy[out] - 1.0) * Ly ** 2 / dy
    lam_x = (Tx[out] / Fx[out] - 1.0) * Lx ** 2 / dx
    assert np.all(lam_y >= 0.0)
    assert np.allclose(lam_y, lam_x, rtol=1e-10, atol=1e-12)


# --------------------------------------------------------------------------- derivatives

def test_output_derivative_is_zero_on_a_plateau_and_exact_while_sliding(make_friction_tire):
    """RLT, Coulomb, at standstill pushed past its limit: on the plateau Fy is held, so
    fmi2GetRealOutputDerivatives gives dFy/dt = 0; the deflection's rate is then exactly 0
    too (the slider takes the motion). SecondOrder sliding: the output derivatives equal
    the difference quotient of two tiny steps."""
    vy = 0.1
    rlt = make_friction_tire("RLT", "Coulomb", vx=0.0, vy=vy)
    rlt.run(np.zeros((1, 3)) + [vy, 0.0, 0.0], 2.0)       # 0.2 m: past Fmax/C_y = 0.114 m
    Fy, = rlt.get("Fy")
    assert Fy == pytest.approx(-0.8 * FZ0, rel=1e-12)
    rates = rlt.fmu.getRealOutputDerivatives([ref.OUTPUT_VR["Fy"], ref.OUTPUT_VR["deflY"]], [1, 1])
    assert rates == [0.0, 0.0]

    tire = make_friction_tire("SecondOrder", "Brush", vx=3.0, vy=-1.5, vsx=0.8)
    tire.run(np.array([[-1.5, 0.0, 0.8]]), 0.5)
    names = ["Fx", "Fy", "Mz", "My", "deflX", "deflY"]
    vrs = [ref.OUTPUT_VR[n] for n in names]
    analytic = np.array(tire.fmu.getRealOutputDerivatives(vrs, [1] * len(vrs)))
    y0 = tire.get(*names)
    dt = 1e-6
    tire.step(dt)
    difference = (tire.get(*names) - y0) / dt
    scale = np.maximum(np.abs(analytic), 1e-3 * np.abs(y0) / 0.01)
    assert np.all(np.abs(difference - analytic) <= 1e-4 * scale), (analytic, difference)


def test_directional_derivative_is_zero_along_a_saturated_direction(make_friction_tire):
    """DDT at standstill, Coulomb: steered fast enough that the yaw moment sits on its
    limit boreRadius muY Fz, dMz/dsteerRate is 0 (the unlimited tire gives dampingPsi);
    pushed sideways past the lateral limit, dFy/dvy is 0 (unlimited: -dampingY)."""
    tire = make_friction_tire("DDT", "Coulomb", vx=0.0, steerRate=0.5)
    tire.step(1.0)                                          # 0.5 rad: far past the yaw limit
    limit = fr.limits(fr.parameters(), FZ0)["psi"]
    Mz, = tire.get("Mz")
    assert abs(Mz) == pytest.approx(limit, rel=1e-12)
    dMz = tire.fmu.getDirectionalDerivative([ref.OUTPUT_VR["Mz"]], [ref.INPUT_VR["steerRate"]], [1.0])
    assert abs(dMz[0]) <= 1e-6 * P["dampingPsi"], dMz

    linear = make_friction_tire("DDT", "Unlimited", vx=0.0, steerRate=0.5)
    linear.step(1.0)
    dMz_linear = linear.fmu.getDirectionalDerivative([ref.OUTPUT_VR["Mz"]], [ref.INPUT_VR["steerRate"]], [1.0])
    assert dMz_linear[0] == pytest.approx(-P["dampingPsi"], rel=1e-12)

    side = make_friction_tire("DDT", "Coulomb", vx=0.0, vy=0.2)
    side.step(1.0)                                          # 0.2 m: past Fmax/C_y
    dFy = side.fmu.getDirectionalDerivative([ref.OUTPUT_VR["Fy"]], [ref.INPUT_VR["vy"]], [1.0])
    assert abs(dFy[0]) <= 1e-6 * P["dampingY"], dFy


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_matches_the_reference_at_a_light_load(make_friction_tire, model):
    """Brush, the first 60 steps of reference_scenario at Fz = 0.005 Fz0: the loaded
    relaxation lengths are short, so the tire's own dynamics are fast against the 10 ms
    steps (a step with sliding goes to the stiff integration); every output equals the
    reference to 1e-7."""
    vx, U, h = reference_scenario(60)
    Fz = 0.005 * FZ0
    tire = make_friction_tire(model, "Brush", params=FRICTION_PARAMS, vx=vx[0], Fz=Fz)
    Y = tire.run(U, h, vx=vx)
    Yref = fr.simulate(model, "Brush", FRICTION_PARAMS, vx, U, h, Fz=Fz)
    assert_close_run(Y, Yref, rtol=1e-7, atol=1e-12, label=f"{model} Brush, Fz {Fz}")
