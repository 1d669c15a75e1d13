"""Measurement helpers shared by the tests: sinusoidal frequency response with ramped
(interpolated) inputs, and a small co-simulation master coupling a wheel mass to the tire.

They work with any object with the conftest.Tire interface (set, set_rates, step,
outputs, run), so the same master runs the FMU and reference.ReferenceTire.
"""

from __future__ import annotations

import math

import numpy as np

import reference as ref

N_PER_PERIOD = 200
WINDOW_PERIODS = 2
TREND_DEGREE = 3


def settle_time(model, p, vx, omega, window):
    """How long to drive before measuring.

    Modes with |lambda| * window <= 1 change slowly over the window and are absorbed by
    the polynomial trend of the fit (as the integrators at rho = 0 are, by its constant);
    every other mode must have decayed by exp(-14).
    """
    A = ref.system(model, p, vx)[0]
    t = 2.0 * math.tau / omega
    for lam in np.linalg.eigvals(A):
        if abs(lam) * window <= 1.0:
            continue
        t = max(t, 14.0 / abs(lam.real))
    return t


def sine_phasor(t, y, omega, degree=TREND_DEGREE):
    """Least squares y ~ poly(t) + a cos(omega t) + b sin(omega t) over the window.
    Returns the complex amplitude c with the periodic part = Re(c exp(j omega t))."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    tc = (t - t.mean()) / (t.max() - t.min())
    M = np.column_stack([tc ** k for k in range(degree + 1)] + [np.cos(omega * t), np.sin(omega * t)])
    scale = np.max(np.abs(y))
    if scale == 0.0:
        return 0j
    coef, *_ = np.linalg.lstsq(M, y / scale, rcond=None)
    a, b = coef[-2] * scale, coef[-1] * scale
    return complex(a, -b)


def frequency_response(tire, model, p, vx, freq, amplitudes, n_per_period=N_PER_PERIOD,
                       window_periods=WINDOW_PERIODS):
    """Drive `tire` (constant vx) with u_i = amp_i sin(omega t), linearly interpolated
    between samples h = period / n_per_period apart (fmi2SetRealInputDerivatives), and
    measure the complex gain of every output to the driven inputs.

    All driven inputs share the frequency, so drive at once only inputs whose paths do not
    overlap in the outputs you read (vy and vsx do not for any model).

    Returns (P, corr, Y, h): P[output] = the output's complex amplitude relative to
    sin(omega t) (divide by an input's amplitude to get the gain to that input);
    corr = sinc^2(omega h / 2), the exact factor by which linear interpolation between
    samples scales the fundamental of a sampled sinusoid (compare P/amp with corr * G);
    Y = the outputs over the measurement window.
    """
    omega = math.tau * freq
    period = 1.0 / freq
    h = period / n_per_period
    window = window_periods * period
    t_settle = settle_time(model, p, vx, omega, window)
    n_settle = int(math.ceil(t_settle / period)) * n_per_period
    n_window = window_periods * n_per_period
    N = n_settle + n_window
    tk = np.arange(N + 1) * h
    S = np.sin(omega * tk)
    amp = np.array([amplitudes.get(name, 0.0) for name in ref.DRIVING])
    Uall = S[:, None] * amp[None, :]
    U = Uall[:-1]
    dU = (Uall[1:] - Uall[:-1]) / h
    tire.set(vx=vx)
    Y = tire.run(U, h, dU=dU)
    t_out = tk[1:]
    sl = slice(n_settle, N)
    x = omega * h / 2.0
    corr = (math.sin(x) / x) ** 2
    G = {}
    for name in ref.OUTPUTS:
        c = sine_phasor(t_out[sl], Y[sl, ref.OUT[name]], omega)
        G[name] = c / (-1j)   # the input sin(omega t) has phasor -j
    return G, corr, Y[sl], h


def gain_phase_error(measured, expected):
    """(gain error in dB, phase error in degrees) of measured vs expected complex gains."""
    ratio = measured / expected
    return 20.0 * math.log10(abs(ratio)), math.degrees(math.atan2(ratio.imag, ratio.real))


# --------------------------------------------------------------------------- wheel mass

def wheel_cosim(tire, m_w, v0, h, n_steps, F_ext=None):
    """A co-simulation master: a wheel of mass m_w moving sideways,
    m_w dv/dt = Fy + F_ext, with v fed to the tire as vy.

    Coupling (symplectic Euler): hold vy = v_k over the step, step the tire exactly, read
    Fy at the end of the step, v_{k+1} = v_k + h (Fy_{k+1} + F_ext_k) / m_w.
    Returns (t, v, Fy) sampled at the communication points (t_0 = 0 included).
    """
    t = np.arange(n_steps + 1) * h
    v = np.empty(n_steps + 1)
    F = np.empty(n_steps + 1)
    v[0] = v0
    F[0] = tire.outputs()[ref.OUT["Fy"]]
    fy = ref.OUT["Fy"]
    fast = getattr(tire, "wheel_loop", None)
    if fast is not None:
        fast(m_w, v, F, h, F_ext)
        return t, v, F
    for k in range(n_steps):
        tire.set(vy=v[k])
        tire.step(h)
        F[k + 1] = tire.outputs()[fy]
        v[k + 1] = v[k] + h * (F[k + 1] + (0.0 if F_ext is None else F_ext[k])) / m_w
    return t, v, F


def zero_crossings(t, v):
    """Times where v changes sign (linear interpolation between samples)."""
    s = np.sign(v)
    idx = np.nonzero((s[:-1] != 0) & (s[:-1] != s[1:]))[0]
    t0, t1, v0, v1 = t[idx], t[idx + 1], v[idx], v[idx + 1]
    return t0 - v0 * (t1 - t0) / (v1 - v0)


def oscillation_frequency(t, v, skip=2):
    """Angular frequency from the mean spacing of zero crossings (skipping the first)."""
    tc = zero_crossings(t, v)[skip:]
    assert len(tc) >= 3, "not enough zero crossings to measure a period"
    half = (tc[-1] - tc[0]) / (len(tc) - 1)
    return math.pi / half


def peaks(v):
    """Values of |v| at local maxima of |v| (one per half cycle)."""
    a = np.abs(v)
    idx = np.nonzero((a[1:-1] >= a[:-2]) & (a[1:-1] > a[2:]))[0] + 1
    return idx, a[idx]
