"""Foundation acceptance: the RLT model is exact (docs/specification.md 4-6).

* Piecewise-constant random vy, steerRate and vsx at five speeds and three step sizes:
  every output equals the exact (matrix exponential) solution to 1e-9 relative.
* Fy / alpha at rho > 0 is Calpha (rho/sigmaY) / (s + rho/sigmaY) (Koo & Tan eq 13).
* At vx = 0 the RLT is an undamped spring of stiffness C_y = Calpha / sigmaY.
* The same exactness through fmpy.simulate_fmu with an input table.
"""

import math

import numpy as np
import pytest

import harness
import reference as ref
from conftest import assert_close_run, random_steps, seed

SPEEDS = [0.0, 0.45, 5.0, 30.0, -5.0]
STEPS = {1e-4: 3000, 1e-2: 600, 0.5: 120}   # step size -> number of steps


@pytest.mark.parametrize("h", list(STEPS))
@pytest.mark.parametrize("vx", SPEEDS)
def test_rlt_piecewise_constant_inputs_are_exact(make_tire, vx, h):
    n = STEPS[h]
    rng = np.random.default_rng(seed(vx, h))
    U = random_steps(rng, n, hold=7, amplitudes=[0.5, 0.3, 0.4])   # vy, steerRate, vsx
    tire = make_tire("RLT", vx=vx)
    y0 = tire.outputs()
    assert np.all(y0 == 0.0), f"outputs at rest must be zero, got {y0}"
    Y = tire.run(U, h)
    Yref = ref.simulate("RLT", ref.parameters(), vx, U, h)
    assert_close_run(Y, Yref, label=f"RLT vx={vx} h={h}")
    # RLT has no steering path and no yaw deflection
    assert np.all(Y[:, ref.OUT["deflPsi"]] == 0.0)


@pytest.mark.parametrize("vx", [5.0, -5.0, 30.0, 0.45])
def test_rlt_cornering_response_is_first_order_lag(make_tire, vx):
    """Fy/alpha = Calpha (rho/sigmaY)/(s + rho/sigmaY), alpha = -vy/rho, at 6 frequencies,
    from sinusoidal vy ramped between samples (input derivatives)."""
    p = ref.parameters()
    rho = abs(vx)
    a = rho / p["sigmaY"]
    freqs = np.geomspace(0.05, 10.0, 6)
    amp_vy = 0.02 * rho
    for f in freqs:
        tire = make_tire("RLT", vx=vx)
        G, corr, _, _ = harness.frequency_response(tire, "RLT", p, vx, f, {"vy": amp_vy})
        s = 1j * math.tau * f
        expected = p["Calpha"] * a / (s + a)                 # Fy / alpha
        measured = G["Fy"] / amp_vy * (-rho)                         # Fy/vy * dvy/dalpha
        dg, dph = harness.gain_phase_error(measured, corr * expected)
        assert abs(dg) <= 0.05 and abs(dph) <= 0.2, (
            f"vx={vx} f={f:.3g} Hz: Fy/alpha gain error {dg:.4f} dB, phase error {dph:.4f} deg "
            f"(measured {abs(measured):.6g} at {math.degrees(np.angle(measured)):.4f} deg, "
            f"expected {abs(expected):.6g} at {math.degrees(np.angle(expected)):.4f} deg)")
        # transient slip angle follows the same lag: alphaT / alpha = a / (s + a)
        dg, dph = harness.gain_phase_error(G["alphaT"] / amp_vy * (-rho), corr * a / (s + a))
        assert abs(dg) <= 0.05 and abs(dph) <= 0.2, f"alphaT/alpha at {f:.3g} Hz: {dg} dB {dph} deg"


def test_rlt_standstill_is_an_undamped_spring(make_tire):
    """Push the wheel sideways at vx = 0, stop: the force stays -C_y * displacement forever."""
    p = ref.parameters()
    C_y = p["Calpha"] / p["sigmaY"]
    tire = make_tire("RLT", vx=0.0)
    v, T, h = 0.02, 0.5, 0.01            # 0.02 m/s for 0.5 s -> 1 cm
    n = int(round(T / h))
    tire.run(np.tile([v, 0.0, 0.0], (n, 1)), h)
    Y = tire.run(np.zeros((30, 3)), 10.0)          # 300 s standing still
    displacement = v * T
    assert np.allclose(Y[:, ref.OUT["deflY"]], displacement, rtol=1e-12, atol=0.0)
    assert np.allclose(Y[:, ref.OUT["Fy"]], -C_y * displacement, rtol=1e-9, atol=0.0)
    assert np.allclose(Y[:, ref.OUT["Mz"]], p["trail"] * C_y * displacement, rtol=1e-9, atol=0.0)
    # also longitudinally: Fx = -C_x * deflX forever
    tire.run(np.tile([0.0, 0.0, -v], (n, 1)), h)
    Y = tire.run(np.zeros((30, 3)), 10.0)
    C_x = p["Ckappa"] / p["sigmaX"]
    assert np.allclose(Y[:, ref.OUT["Fx"]], C_x * displacement, rtol=1e-9, atol=0.0)
    assert np.allclose(Y[:, ref.OUT["My"]], -p["Re"] * C_x * displacement, rtol=1e-9, atol=0.0)


def test_rlt_standstill_free_oscillation_does_not_decay(make_tire):
    """A wheel mass on the standing RLT tire oscillates at sqrt(C_y/m_w) without decay."""
    p = ref.parameters()
    m_w = 3000.0
    omega0 = math.sqrt(p["Calpha"] / p["sigmaY"] / m_w)
    h = 1e-3
    n = int(round(8 * math.tau / omega0 / h))
    tire = make_tire("RLT", vx=0.0)
    t, v, F = harness.wheel_cosim(tire, m_w, 0.1, h, n)
    omega = harness.oscillation_frequency(t, v)
    assert abs(omega / omega0 - 1.0) < 1e-3, f"free oscillation at {omega} rad/s, expected {omega0}"
    _, pk = harness.peaks(v)
    assert len(pk) >= 12
    assert np.max(np.abs(pk / pk[0] - 1.0)) < 1e-3, f"peak velocities drift: {pk}"
    # and the master's run through the reference is the same to 1e-9
    _, v_ref, F_ref = harness.wheel_cosim(ref.ReferenceTire("RLT", vx=0.0), m_w, 0.1, h, n)
    assert np.max(np.abs(v - v_ref)) <= 1e-9 * np.max(np.abs(v_ref))
    assert np.max(np.abs(F - F_ref)) <= 1e-9 * np.max(np.abs(F_ref))


def test_rlt_through_fmpy_simulate_fmu(fmu_path):
    """fmpy.simulate_fmu with an input table (steps as duplicate time points)."""
    from fmpy import simulate_fmu

    vx = 4.0
    h = 0.01
    breaks = [0.0, 0.3, 0.7, 1.2, 1.5, 2.0]                 # input changes at these times
    vy_vals = [0.05, -0.1, 0.0, 0.2, -0.03]
    vsx_vals = [0.0, 0.08, -0.05, 0.02, 0.1]
    rows = []
    for i, (vy, vsx) in enumerate(zip(vy_vals, vsx_vals)):
        rows.append((breaks[i], vx, vy, vsx))
        rows.append((breaks[i + 1], vx, vy, vsx))
    dtype = [("time", np.float64), ("vx", np.float64), ("vy", np.float64), ("vsx", np.float64)]
    signals = np.array(rows, dtype=dtype)
    stop = breaks[-1]
    res = simulate_fmu(fmu_path, start_time=0.0, stop_time=stop, output_interval=h,
                       start_values={"tireModel": 1, "friction": 1}, input=signals,
                       output=ref.OUTPUTS, fmi_type="CoSimulation")
    t = res["time"]
    assert t[0] == 0.0 and abs(t[-1] - stop) < 1e-9
    # reference: one exact ZOH step per output interval, inputs of the segment
    n = int(round(stop / h))
    tk = np.arange(n) * h
    seg = np.searchsorted(np.array(breaks[1:]), tk + 1e-9 * h, side="right")
    U = np.column_stack([np.take(vy_vals, seg), np.zeros(n), np.take(vsx_vals, seg)])
    Yref = ref.simulate("RLT", ref.parameters(), vx, U, h)
    Y = np.column_stack([res[name] for name in ref.OUTPUTS])
    assert len(t) == n + 1
    assert np.allclose(t[1:], (np.arange(n) + 1) * h, rtol=0, atol=1e-9)
    assert np.all(Y[0] == 0.0)
    assert_close_run(Y[1:], Yref, label="simulate_fmu RLT")
