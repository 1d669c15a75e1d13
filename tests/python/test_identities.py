"""Physical identities of docs/specification.md 5 with the snowblower tire of docs/specification.md 9.

* every model: steady state Fy = Calpha alpha, Fx = Ckappa kappa; static stiffness C_y, C_x;
* at rho = 0: RLT is an undamped spring, DDT, SecondOrder and RingBody are damped
  (free vibration of a wheel mass in a small co-simulation master);
* the wheel-mass resonance of Koo & Tan eqs 41 (RLT) and 44 (DDT):
  v_s/F_ext = (s + a)/(m_w s^2 + (m_w a + D) s + C_y);
* SecondOrder tends to Kim's first-order lag tau = Calpha/(k_y vx) as the contact mass,
  carcass damping and tread relaxation length go to zero.
"""

import math

import numpy as np
import pytest

import harness
import reference as ref

SNOW = ref.SNOWBLOWER
M_WHEEL = 3000.0          # kg: the wheel (a share of the 20.5 t vehicle)
H_COSIM = 2e-4            # s: communication step of the wheel master


def _rel(a, b):
    return abs(a - b) / abs(b)


@pytest.mark.parametrize("vx", [5.0, -5.0])
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_steady_state_slip_stiffness(make_tire, model, vx):
    """Constant slip: Fy = Calpha alpha and Fx = Ckappa kappa (alpha = -vy/rho,
    kappa = -vsx/rho), alphaT = alpha, kappaT = kappa, Mz = -trail Fy, My = -Re Fx."""
    p = ref.parameters(**SNOW)
    rho = abs(vx)
    vy, vsx = -0.35, 0.2
    alpha, kappa = -vy / rho, -vsx / rho
    tire = make_tire(model, params=SNOW, vx=vx)
    Y = tire.run(np.tile([vy, 0.0, vsx], (4, 1)), 10.0)     # 40 s: every mode has decayed
    y = dict(zip(ref.OUTPUTS, Y[-1]))
    assert _rel(y["Fy"], p["Calpha"] * alpha) < 1e-9, (y["Fy"], p["Calpha"] * alpha)
    assert _rel(y["Fx"], p["Ckappa"] * kappa) < 1e-9, (y["Fx"], p["Ckappa"] * kappa)
    assert _rel(y["alphaT"], alpha) < 1e-9
    assert _rel(y["kappaT"], kappa) < 1e-9
    assert _rel(y["deflY"], -p["sigmaY"] * alpha) < 1e-9
    assert _rel(y["deflX"], -p["sigmaX"] * kappa) < 1e-9
    assert _rel(y["Mz"], -p["trail"] * y["Fy"]) < 1e-9
    assert _rel(y["My"], -p["Re"] * y["Fx"]) < 1e-9
    assert y["deflPsi"] == 0.0
    # still there 10 s later
    y2 = tire.run(np.array([[vy, 0.0, vsx]]), 10.0)[-1]
    assert np.allclose(y2, Y[-1], rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_static_stiffness_at_standstill(make_tire, model):
    """vx = 0: push the wheel by Y sideways and X forward, hold: Fy = -C_y Y, Fx = -C_x X."""
    p = ref.parameters(**SNOW)
    C_y = p["Calpha"] / p["sigmaY"]
    C_x = p["Ckappa"] / p["sigmaX"]
    tire = make_tire(model, params=SNOW, vx=0.0)
    vy, vsx, T, h = 0.03, -0.02, 0.4, 1e-3
    n = int(round(T / h))
    tire.run(np.tile([vy, 0.0, vsx], (n, 1)), h)
    Y = tire.run(np.zeros((3, 3)), 10.0)
    Yd, Xd = vy * n * h, vsx * n * h
    for y in Y:
        y = dict(zip(ref.OUTPUTS, y))
        assert _rel(y["deflY"], Yd) < 1e-9, (y["deflY"], Yd)
        assert _rel(y["deflX"], Xd) < 1e-9, (y["deflX"], Xd)
        assert _rel(y["Fy"], -C_y * Yd) < 1e-9, (model, y["Fy"], -C_y * Yd)
        assert _rel(y["Fx"], -C_x * Xd) < 1e-9, (model, y["Fx"], -C_x * Xd)
        assert _rel(y["alphaT"], -Yd / p["sigmaY"]) < 1e-9


def _closed_loop_mode(model, p, vx, m_w):
    """Dominant (slowest oscillatory) closed-loop eigenvalue of tire + wheel mass from the
    reference state space: x' = A x + B vy, m_w v' = C_Fy x + D_Fy v."""
    A, B, C, D = ref.system(model, p, vx)
    n = A.shape[0]
    fy = ref.OUT["Fy"]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n] = A
    M[:n, n] = B[:, 0]
    M[n, :n] = C[fy] / m_w
    M[n, n] = D[fy, 0] / m_w
    lam = np.linalg.eigvals(M)
    osc = lam[lam.imag > 1e-9]
    return osc[np.argmin(np.abs(osc))]


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_free_vibration_at_standstill(make_tire, model):
    """A wheel mass on the tire at vx = 0, released with a lateral velocity:
    RLT keeps oscillating at constant amplitude, the others decay."""
    p = ref.parameters(**SNOW)
    C_y = p["Calpha"] / p["sigmaY"]
    omega0 = math.sqrt(C_y / M_WHEEL)
    n = int(round(6 * math.tau / omega0 / H_COSIM))
    tire = make_tire(model, params=SNOW, vx=0.0)
    t, v, F = harness.wheel_cosim(tire, M_WHEEL, 0.1, H_COSIM, n)
    assert np.all(np.isfinite(v)) and np.all(np.isfinite(F))
    idx, pk = harness.peaks(v)
    ratio = pk[-1] / pk[0]
    decay = math.log(pk[-1] / pk[1]) / (t[idx[-1]] - t[idx[1]])
    lam = _closed_loop_mode(model, p, 0.0, M_WHEEL)
    if model == "RLT":
        assert abs(ratio - 1.0) < 1e-3, f"RLT at standstill must be undamped: peaks {pk}"
        assert lam.real == pytest.approx(0.0, abs=1e-9)
    else:
        assert ratio < 0.2, f"{model} at standstill must be damped: amplitude ratio {ratio} after 6 cycles"
        if model == "DDT":
            expected = -p["dampingY"] / (2 * M_WHEEL)          # eq 44 with a = 0
        else:
            expected = lam.real
        assert _rel(decay, expected) < 0.01, f"{model}: decay rate {decay}, expected {expected}"
    # the FMU in the loop gives the same trajectory as the reference in the loop
    _, v_ref, F_ref = harness.wheel_cosim(ref.ReferenceTire(model, params=SNOW, vx=0.0),
                                          M_WHEEL, 0.1, H_COSIM, n)
    assert np.max(np.abs(v - v_ref)) <= 1e-9 * np.max(np.abs(v_ref))
    assert np.max(np.abs(F - F_ref)) <= 1e-9 * np.max(np.abs(F_ref))


@pytest.mark.parametrize("vx", [0.0, 2.0, 5.0, -5.0])
@pytest.mark.parametrize("model", ["RLT", "DDT"])
def test_wheel_mass_resonance_koo_tan(make_tire, model, vx):
    """Koo & Tan eqs 41/44: the free vibration of the wheel mass oscillates at the damped
    natural frequency of m_w s^2 + (m_w a + D) s + C_y (within 1 %), and decays at its
    real part (within 1 %)."""
    p = ref.parameters(**SNOW)
    roots = np.roots(ref.wheel_mass_polynomial(p, vx, M_WHEEL, model))
    root = roots[np.argmax(roots.imag)]
    omega_d = root.imag
    assert omega_d > 0
    n = int(round(5 * math.tau / omega_d / H_COSIM))
    tire = make_tire(model, params=SNOW, vx=vx)
    t, v, F = harness.wheel_cosim(tire, M_WHEEL, 0.1, H_COSIM, n)
    omega = harness.oscillation_frequency(t, v, skip=1)
    assert _rel(omega, omega_d) < 0.01, (
        f"{model} vx={vx}: resonance {omega / math.tau:.4f} Hz, Koo & Tan {omega_d / math.tau:.4f} Hz")
    idx, pk = harness.peaks(v)
    decay = math.log(pk[-1] / pk[0]) / (t[idx[-1]] - t[idx[0]])
    if root.real == 0.0:
        assert abs(decay) < 1e-4
    else:
        assert _rel(decay, root.real) < 0.01, f"{model} vx={vx}: decay {decay}, expected {root.real}"


@pytest.mark.parametrize("vx", [5.0, 20.0])
def test_second_order_tends_to_kim_first_order_lag(make_tire, vx):
    """contactMass, carcassDampingY, sigmaTread -> 0: Fy/alpha -> Calpha/(1 + tau s),
    tau = Calpha/(k_y vx) (Kim eq 10), within 0.05 dB / 0.2 deg; and the limit is
    approached (the error shrinks as the parameters shrink)."""
    freqs = np.geomspace(0.1, 5.0, 5)
    tiny = dict(SNOW, contactMass=1e-4, carcassDampingY=1e-3, sigmaTread=1e-4)
    small = dict(SNOW, contactMass=1.0, carcassDampingY=100.0, sigmaTread=0.05)
    rho = abs(vx)
    amp = 0.02 * rho
    errors = {}
    for name, params in (("tiny", tiny), ("small", small)):
        p = ref.parameters(**params)
        k_y = p["Calpha"] / (p["sigmaY"] - p["sigmaTread"])
        tau = p["Calpha"] / (k_y * rho)
        errs = []
        for f in freqs:
            tire = make_tire("SecondOrder", params=params, vx=vx)
            P, corr, _, _ = harness.frequency_response(tire, "SecondOrder", p, vx, f, {"vy": amp})
            measured = P["Fy"] / amp * (-rho)                  # Fy / alpha
            kim = p["Calpha"] / (1.0 + tau * 1j * math.tau * f)
            errs.append(harness.gain_phase_error(measured, corr * kim))
        errors[name] = np.array(errs)
    for (dg, dph), f in zip(errors["tiny"], freqs):
        assert abs(dg) <= 0.05 and abs(dph) <= 0.2, f"vx={vx} f={f:.3g} Hz: {dg:+.4f} dB {dph:+.4f} deg from Kim's lag"
    worst_tiny = np.max(np.abs(errors["tiny"]), axis=0)
    worst_small = np.max(np.abs(errors["small"]), axis=0)
    assert np.all(worst_tiny < worst_small), (worst_tiny, worst_small)
