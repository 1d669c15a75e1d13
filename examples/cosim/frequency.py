"""Frequency responses and modes from co-simulated signals.

* ``Multisine``: a periodic excitation, a sum of sines at integer multiples (harmonics) of
  a base frequency, with Schroeder phases so that its peak stays low.
* ``frequency_response``: the complex gain output/input at the excited frequencies, from
  whole periods of the steady part of a run (a DFT at the excited bins).
* ``fit_rational``: a rational transfer function fitted to a frequency response
  (Sanathanan-Koerner iteration); its poles give natural frequencies and damping ratios.
* ``era_poles``: the poles and output mode shapes of a sampled free response
  (Eigensystem Realization Algorithm), for modes a steer input cannot excite or that
  are undamped.

The excitation is sampled at the communication points and is linear in between (the
tire inputs get its rate). A piecewise linear sine of angular frequency w sampled every h
has, at w, the amplitude of the samples times sinc^2(w h/2); ``frequency_response``
divides this factor out, so the gain is that of the continuous system to the signal
actually applied.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Multisine:
    """sum_i a sin(2 pi n_i f0 t + phi_i), repeating every 1/f0 seconds.

    base_frequency: f0 [Hz]; harmonics: the integers n_i; amplitude: the peak of the sum
    (in the unit of the excited input). Schroeder phases phi_i = -pi i (i - 1)/K.
    """

    base_frequency: float
    harmonics: tuple[int, ...]
    amplitude: float

    @property
    def frequencies(self) -> np.ndarray:
        """The excited frequencies [Hz]."""
        return np.asarray(self.harmonics, dtype=float) * self.base_frequency

    @property
    def period(self) -> float:
        return 1.0 / self.base_frequency

    def _phases(self) -> np.ndarray:
        K = len(self.harmonics)
        i = np.arange(1, K + 1)
        return -math.pi * i * (i - 1) / K

    def _component_amplitude(self) -> float:
        # scale so that the peak of one period (on a fine grid) is `amplitude`
        t = np.linspace(0.0, self.period, 20 * max(self.harmonics) + 1)
        peak = np.max(np.abs(self._unit(t)))
        return self.amplitude / peak

    def _unit(self, t):
        t = np.asarray(t, dtype=float)
        w = 2.0 * math.pi * self.frequencies
        return np.sin(np.multiply.outer(t, w) + self._phases()).sum(axis=-1)

    def __call__(self, t) -> np.ndarray:
        return self._component_amplitude() * self._unit(t)


def log_harmonics(f_min: float, f_max: float, base_frequency: float, count: int) -> tuple[int, ...]:
    """About `count` harmonics of base_frequency spread evenly on a log scale over
    [f_min, f_max] (duplicates merged)."""
    lo = max(1, math.ceil(f_min / base_frequency - 1e-9))
    hi = math.floor(f_max / base_frequency + 1e-9)
    values = np.unique(np.round(np.geomspace(lo, hi, count)).astype(int))
    return tuple(int(v) for v in values)


def steps_per_period(excitation: Multisine, h: float) -> int:
    P = excitation.period / h
    if abs(P - round(P)) > 1e-6 * P:
        raise ValueError(f"the period {excitation.period} s is not a whole number of {h} s steps")
    return int(round(P))


def frequency_response(u: np.ndarray, y: np.ndarray, excitation: Multisine, h: float,
                       periods: int = 1) -> np.ndarray:
    """Complex gain y/u at ``excitation.frequencies`` from the last `periods` whole periods
    of the samples u_k, y_k (taken at t_k = k h). The sinc^2 factor of the linear
    interpolation of u between samples is divided out (see module doc)."""
    P = steps_per_period(excitation, h)
    n = P * periods
    if len(u) < n or len(y) < n:
        raise ValueError(f"need {n} samples for {periods} period(s), have {len(y)}")
    bins = np.asarray(excitation.harmonics) * periods
    U = np.fft.rfft(np.asarray(u[-n:], float))[bins]
    Y = np.fft.rfft(np.asarray(y[-n:], float))[bins]
    x = math.pi * np.asarray(excitation.harmonics) / P          # w h / 2
    hold = (np.sin(x) / x) ** 2
    return Y / (U * hold)


# --------------------------------------------------------------------------- rational fit

@dataclass(frozen=True)
class RationalFit:
    """H(s) = num(s)/den(s), polynomials in s [rad/s] (highest power first, as np.polyval)."""

    num: np.ndarray
    den: np.ndarray

    def __call__(self, freq_hz) -> np.ndarray:
        s = 2j * math.pi * np.asarray(freq_hz, dtype=float)
        return np.polyval(self.num, s) / np.polyval(self.den, s)

    @property
    def poles(self) -> np.ndarray:
        return np.roots(self.den)


def fit_rational(freq_hz, H, num_order: int, den_order: int, iterations: int = 60,
                 tol: float = 1e-13) -> RationalFit:
    """Least-squares fit of num/den (orders given, den monic) to the complex response H
    at freq_hz, by Sanathanan-Koerner iteration: the linearised error N - H D is weighted
    by 1/|D| of the previous iteration until the denominator settles. s is scaled by the
    geometric mean of the angular frequencies to keep the system well conditioned."""
    f = np.asarray(freq_hz, dtype=float)
    H = np.asarray(H, dtype=complex)
    w0 = 2.0 * math.pi * math.exp(np.mean(np.log(f)))
    x = 2j * math.pi * f / w0
    Vn = np.column_stack([x ** j for j in range(num_order + 1)])
    Vd = np.column_stack([x ** j for j in range(den_order)])
    rhs_x = x ** den_order
    weight = np.ones(len(f))
    a = np.zeros(den_order)
    for _ in range(iterations):
        M = np.hstack([Vn, -H[:, None] * Vd]) * weight[:, None]
        rhs = H * rhs_x * weight
        Mr = np.vstack([M.real, M.imag])
        br = np.concatenate([rhs.real, rhs.imag])
        sol, *_ = np.linalg.lstsq(Mr, br, rcond=None)
        b, a_new = sol[:num_order + 1], sol[num_order + 1:]
        D = Vd @ a_new + rhs_x
        weight = 1.0 / np.abs(D)
        converged = np.max(np.abs(a_new - a)) <= tol * max(1.0, np.max(np.abs(a_new)))
        a = a_new
        if converged:
            break
    # back to s = w0 x: coefficient of s^j is c_j / w0^j; normalise den to monic in s
    num_s = np.array([b[j] / w0 ** j for j in range(num_order + 1)])[::-1]
    den_x = np.concatenate([a, [1.0]])
    den_s = np.array([den_x[j] / w0 ** j for j in range(den_order + 1)])[::-1]
    lead = den_s[0]
    return RationalFit(num_s / lead, den_s / lead)


@dataclass(frozen=True)
class Mode:
    frequency: float   # undamped natural frequency [Hz]
    damping: float     # damping ratio [1]
    pole: complex      # [rad/s]


def oscillatory_modes(poles) -> list[Mode]:
    """One Mode per complex-conjugate pair (Im > 0), sorted by frequency."""
    modes = []
    for p in np.asarray(poles, dtype=complex):
        if p.imag > 1e-9 * abs(p):
            wn = abs(p)
            modes.append(Mode(wn / (2.0 * math.pi), -p.real / wn, complex(p)))
    return sorted(modes, key=lambda m: m.frequency)


# --------------------------------------------------------------------------- ERA

def era_poles(y: np.ndarray, h: float, order: int, rows: int | None = None):
    """Poles [rad/s] and output mode shapes of a sampled free response y (N samples x p
    outputs, taken every h seconds), by the Eigensystem Realization Algorithm: a Hankel
    matrix of the samples, its rank-`order` SVD, and the shift invariance of the
    observability matrix. Exact (up to rounding) for the free response of a linear
    discrete system of that order; continuous poles are log(z)/h.

    Returns (poles, shapes) with shapes[:, i] the outputs' complex amplitudes in mode i.
    """
    y = np.asarray(y, dtype=float)
    if y.ndim == 1:
        y = y[:, None]
    N, p = y.shape
    rows = rows or max(order + 1, min(N // 3, 4 * order))
    cols = N - rows + 1
    if cols < order:
        raise ValueError("too few samples for this order")
    Hk = np.vstack([y[i:i + cols].T for i in range(rows)])     # (rows p) x cols
    Uh, sv, _ = np.linalg.svd(Hk, full_matrices=False)
    Obs = Uh[:, :order] * np.sqrt(sv[:order])
    Ad = np.linalg.lstsq(Obs[:-p], Obs[p:], rcond=None)[0]
    z, vecs = np.linalg.eig(Ad)
    poles = np.log(z.astype(complex)) / h
    shapes = Obs[:p] @ vecs
    return poles, shapes


# --------------------------------------------------------------------------- measuring

def measure_response(vehicle, h: float, excitation: Multisine, settle_time: float,
                     drive: str = "steer", measure: str = "r", periods: int = 1):
    """Co-simulate `vehicle` (a coupling.VehicleModel) with its external input `drive`
    following `excitation`, for settle_time (rounded up to whole periods, so that the
    transient dies out) and then `periods` periods, and return
    (complex gain measure/drive at excitation.frequencies, the Trajectory)."""
    from .coupling import CoSimulation

    P = steps_per_period(excitation, h)
    n_settle = math.ceil(settle_time / excitation.period - 1e-9) * P
    N = n_settle + periods * P
    t = np.arange(N + 1) * h
    W = np.zeros((N + 1, len(vehicle.external_names)))
    W[:, vehicle.external_names.index(drive)] = excitation(t)
    sim = CoSimulation(vehicle, h)
    traj = sim.run(W)
    H = frequency_response(traj.ext(drive), traj.state(measure), excitation, h, periods)
    return H, traj


def sampled_response(H, freq_hz, h: float, terms: int = 200, hold: str = "ramp") -> np.ndarray:
    """What ``frequency_response`` measures on a linear system with frequency response H
    (a function of frequency in Hz) driven by a sine sampled every h and, between the
    samples, (hold = "ramp") interpolated linearly: the interpolated sine holds, besides
    the fundamental, components at f + m/h (m = +-1, +-2, ...) with weights
    w_m = sin^2(x)/(x + m pi)^2, x = pi f h (they sum to 1), and sampling the output folds
    them all back onto f. So the measurement is sum_m H(f + m/h) w_m / w_0. The sum is
    taken over |m| <= terms, and the rest (weights ~ 1/m^2) at the value of H far up,
    where it is flat.

    hold = "mean": the FMI 3.0 tire of ``tire.TireLag`` (no input derivatives), which
    holds each step's input at the mean of its two samples and gives the outputs with the
    input at the sample. The held signal's components at f + m/h have the weights
    c_m = sin(x) cos(x)/(x + m pi); the states follow them, and the direct feedthrough
    D = H(infinity) sees the sample itself: the measurement is
    (D + sum_m (H(f + m/h) - D) c_m) / w_0, with w_0 the ramp's factor that
    ``frequency_response`` divides out. These terms fall off as 1/m^2 only (c_m ~ 1/m,
    H - D ~ 1/m): the sum runs to |m| <= 100 terms, and the rest is extrapolated."""
    f = np.asarray(freq_hz, dtype=float)
    x = math.pi * f * h
    fs = 1.0 / h
    w0 = (np.sin(x) / x) ** 2
    if hold == "mean":
        D = H(f + 1e9 * fs)[:, None]
        sc = (np.cos(x) * np.sin(x))[:, None]
        m = np.arange(1, 100 * terms + 1)
        pairs = sum((H(f[:, None] + k * fs) - D) * sc / (x[:, None] + k * math.pi) for k in (m, -m))
        partial = np.cumsum(pairs, axis=1)
        # the tail after M pairs goes as 1/M: Richardson from the sums to M/2 and to M
        tail_free = 2.0 * partial[:, -1] - partial[:, len(m) // 2 - 1]
        return (D[:, 0] + (H(f) - D[:, 0]) * sc[:, 0] / x + tail_free) / w0
    if hold != "ramp":
        raise ValueError(f"hold is 'ramp' or 'mean', not {hold!r}")
    total = np.zeros(f.shape, dtype=complex)
    weight_sum = np.zeros(f.shape)
    for m in range(-terms, terms + 1):
        w = np.sin(x) ** 2 / (x + m * math.pi) ** 2
        total += w * H(f + m * fs)
        weight_sum += w
    far = 0.5 * (H(f + (terms + 1) * fs) + H(f - (terms + 1) * fs))
    total += (1.0 - weight_sum) * far
    return total / w0
