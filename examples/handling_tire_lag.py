#!/usr/bin/env python3
"""Handling with tire lag: natural frequency and damping of a car on RLT tires (Kim 2008).

Kim (2008) models a car as a bicycle whose axle forces lag the slip angle by a first-order
lag, F_i = C_i/(1 + tau_i s) alpha_i with tau_i = sigma_i/V (eqs 8-10, 16), and derives
from a Taylor expansion of the lag, C_i (1 - tau_i s), a second-order characteristic
equation for the yaw/sideslip mode (eq 19):

    s^2 + (A1 + A1')/(A0 + A0') s + A2/(A0 + A0') = 0
    A0 = m V Iz
    A0' = l^2 C1 C2 tau1 tau2/V - m (a^2 C1 tau1 + b^2 C2 tau2) - Iz (C1 tau1 + C2 tau2)
    A1 = m (a^2 C1 + b^2 C2) + Iz (C1 + C2)
    A1' = -(l^2 C2/V - a m V) C1 tau1 - (l^2 C1/V + b m V) C2 tau2
    A2 = l^2 C1 C2/V - m V (a C1 - b C2)

(without lag, A0' = A1' = 0 gives eq 19c, d). The extraction of eq 19 lost a sign in A1'
(it prints "bmV-" where the expansion gives + b m V; Cz in eq 19 shows the + sign); the
terms above are re-derived from eq 15 with C_i* = C_i (1 - tau_i s).

With RLT tires (the TireLag FMU, tireModel = RLT: Fy/alpha = Calpha/(1 + (sigmaY/V) s)) the
bicycle model is of fourth order. This script co-simulates it across speeds, measures the
yaw-rate/steer frequency response with a multisine, fits a rational transfer function to
it and takes the handling mode (the two poles nearest the origin; the other poles are the
fast tire lags V/sigma) as natural frequency wn and damping ratio zeta. It compares them
with the exact fourth-order linear model (the roots of eq 15's characteristic polynomial
with the exact lag C_i/(1 + tau_i s)) and with eq 19, for four cases: no lag, front lag
only, rear lag only, lag on both axles (an axle without lag has a Python tire without lag).

The car: a mid-size car, the Cadillac SRX parameter set of Althoff & Dolan (2014) as
shipped with Drake's BicycleCar (drake/automotive/bicycle_car.cc): m = 2278 kg,
Iz = 3210 kg.m2, a = 1.292 m, b = 1.515 m, axle cornering stiffnesses C1 = C2 = 108000
N/rad (here two tires of 54000 N/rad per axle). The relaxation length is Kim's: his
identified rear-axle lag tau2 = 0.02 s at 33.3 m/s (Fig 5) is sigma = 0.67 m, used on
every lagged axle. No pneumatic trail (Kim's model has none).

Kim's conclusion to check: lag changes wn and zeta*wn markedly; a front lag raises the
damping coefficient zeta*wn and a rear lag lowers it, so a car with tau1 > tau2 is more
stable. Speeds start at 25 m/s: below that the lag poles (V/sigma) come close to the
handling poles, the modes mix, and eq 19's Taylor expansion (tau s << 1) no longer holds.

Writes out/handling_tire_lag.png (wn, zeta and zeta*wn against speed: co-simulation,
exact model, eq 19, for each case) and out/handling_tire_lag.csv (case, speed [m/s],
source, wn [rad/s], natural frequency [Hz], zeta [1], zeta*wn [1/s]).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
from numpy.polynomial import polynomial as P

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cosim import (Bicycle, BicycleParameters, Multisine, SteadyStateTire, TireLag,  # noqa: E402
                   fit_rational, load_fmu, log_harmonics)
from cosim.cli import print_table, run_example, write_csv  # noqa: E402
from cosim.frequency import measure_response  # noqa: E402

NAME = "handling_tire_lag"
# Cadillac SRX (Althoff & Dolan 2014, as in Drake's BicycleCar)
CAR = BicycleParameters(mass=2278.0, yaw_inertia=3210.0, front_distance=1.292, rear_distance=1.515,
                        tires_per_axle=2)
AXLE_CALPHA = 108000.0                     # N/rad per axle
TIRE_CALPHA = AXLE_CALPHA / CAR.tires_per_axle
SIGMA = 0.02 * 33.3                        # m: Kim's tau2 = 0.02 s at 33.3 m/s
CASES = {"no lag": (False, False), "front lag": (True, False), "rear lag": (False, True),
         "both lagged": (True, True)}
STEER_AMPLITUDE = math.radians(0.5)


def settings(quick: bool) -> dict:
    if quick:
        return {"speeds": (100 / 3.6, 33.3), "h": 0.002, "base": 0.2, "count": 16, "settle": 3.0}
    return {"speeds": (25.0, 100 / 3.6, 30.0, 33.3, 35.0, 40.0, 45.0), "h": 0.002, "base": 0.2,
            "count": 25, "settle": 4.0}


# --------------------------------------------------------------------------- analytic

def taus(case: str, speed: float) -> tuple[float, float]:
    front, rear = CASES[case]
    return (SIGMA / speed if front else 0.0, SIGMA / speed if rear else 0.0)


def exact_poles(speed: float, tau1: float, tau2: float) -> np.ndarray:
    """Roots of Kim's eq 15 determinant with C_i* = C_i/(1 + tau_i s), times (1 + tau1 s)(1 + tau2 s):
    m V Iz s^2 P1 P2 + m s (a^2 C1 P2 + b^2 C2 P1) + Iz s (C1 P2 + C2 P1) + l^2 C1 C2/V
    - m V (a C1 P2 - b C2 P1), with P_i = 1 + tau_i s (using S Q - P^2 = l^2 C1* C2*)."""
    m, Iz, a, b, V = CAR.mass, CAR.yaw_inertia, CAR.front_distance, CAR.rear_distance, speed
    l, C1, C2 = a + b, AXLE_CALPHA, AXLE_CALPHA
    P1, P2 = np.array([1.0, tau1]), np.array([1.0, tau2])        # ascending powers of s
    poly = P.polymul(P.polymul([0.0, 0.0, m * V * Iz], P1), P2)
    poly = P.polyadd(poly, P.polymul([0.0, m], P.polyadd(a * a * C1 * P2, b * b * C2 * P1)))
    poly = P.polyadd(poly, P.polymul([0.0, Iz], P.polyadd(C1 * P2, C2 * P1)))
    poly = P.polyadd(poly, [l * l * C1 * C2 / V])
    poly = P.polysub(poly, m * V * P.polysub(a * C1 * P2, b * C2 * P1))
    poly = np.trim_zeros(poly, "b")
    return P.polyroots(poly)


def eq19(speed: float, tau1: float, tau2: float) -> tuple[float, float]:
    """(wn [rad/s], zeta) of Kim's eq 19 (with tau = 0: eq 19c, d)."""
    m, Iz, a, b, V = CAR.mass, CAR.yaw_inertia, CAR.front_distance, CAR.rear_distance, speed
    l, C1, C2 = a + b, AXLE_CALPHA, AXLE_CALPHA
    A0 = m * V * Iz
    A0p = l * l * C1 * C2 * tau1 * tau2 / V - m * (a * a * C1 * tau1 + b * b * C2 * tau2) \
        - Iz * (C1 * tau1 + C2 * tau2)
    A1 = m * (a * a * C1 + b * b * C2) + Iz * (C1 + C2)
    A1p = -(l * l * C2 / V - a * m * V) * C1 * tau1 - (l * l * C1 / V + b * m * V) * C2 * tau2
    A2 = l * l * C1 * C2 / V - m * V * (a * C1 - b * C2)
    wn = math.sqrt(A2 / (A0 + A0p))
    return wn, (A1 + A1p) / (2.0 * (A0 + A0p)) / wn


def handling_mode(poles) -> tuple[float, float]:
    """(wn, zeta) of the complex pair nearest the origin, or, without one, of the two real
    poles nearest it (an overdamped mode): wn^2 = p1 p2, 2 zeta wn = -(p1 + p2). The pair
    first, because with both axles lagged the fit's fourth pole (the lag it barely sees
    below 5 Hz) can land anywhere on the real axis, also near the origin."""
    poles = sorted(np.asarray(poles, dtype=complex), key=abs)
    pairs = [q for q in poles if q.imag > 1e-9 * abs(q)]
    p = [pairs[0], pairs[0].conjugate()] if pairs else poles[:2]
    wn = math.sqrt((p[0] * p[1]).real)
    return wn, -(p[0] + p[1]).real / (2.0 * wn)


# --------------------------------------------------------------------------- co-simulation

def car(fmu, speed: float, case: str) -> Bicycle:
    lag_front, lag_rear = CASES[case]
    params = {"Calpha": TIRE_CALPHA, "sigmaY": SIGMA, "trail": 0.0}

    def tire(name, lagged):
        if lagged:
            return TireLag(fmu, "RLT", params, name=name, inputs=("vy",), outputs=("Fy", "Mz"),
                           friction="Unlimited")   # Kim's linear model: no friction limit
        return SteadyStateTire(TIRE_CALPHA, 0.0, name=name)

    return Bicycle(CAR, speed, tire("front", lag_front), tire("rear", lag_rear))


def fit_orders(case: str) -> tuple[int, int]:
    """(numerator, denominator) order of r/steer: 2 + one per lagged axle; the steer
    reaches the yaw acceleration through one lag (relative degree 2) when the front axle
    lags, directly (relative degree 1) when it does not."""
    lag_front, lag_rear = CASES[case]
    den = 2 + lag_front + lag_rear
    return den - (2 if lag_front else 1), den


def simulate(fmu_path, quick: bool = False) -> dict:
    fmu = load_fmu(fmu_path)
    s = settings(quick)
    exc = Multisine(s["base"], log_harmonics(s["base"], 5.0, s["base"], s["count"]), STEER_AMPLITUDE)
    rows = {}
    fits = {}
    for speed in s["speeds"]:
        for case in CASES:
            with car(fmu, speed, case) as vehicle:
                H, _ = measure_response(vehicle, s["h"], exc, s["settle"])
            num, den = fit_orders(case)
            fit = fit_rational(exc.frequencies, H, num, den)
            t1, t2 = taus(case, speed)
            rows[case, speed] = {"cosim": handling_mode(fit.poles),
                                 "exact": handling_mode(exact_poles(speed, t1, t2)),
                                 "eq19": eq19(speed, t1, t2)}
            fits[case, speed] = (H, fit, float(np.max(np.abs(fit(exc.frequencies) / H - 1.0))))
    return {"speeds": s["speeds"], "modes": rows, "fits": fits, "excitation": exc, "h": s["h"]}


def report(res: dict) -> None:
    print(f"Handling mode of a mid-size car on RLT tires (Kim 2008, eq 19): sigma = {SIGMA:.2f} m")
    table = []
    for (case, speed), m in res["modes"].items():
        (wc, zc), (we, ze), (w19, z19) = m["cosim"], m["exact"], m["eq19"]
        table.append([case, f"{speed:.1f}", wc, zc, zc * wc, 100 * (wc / we - 1), 100 * (zc / ze - 1),
                      w19, z19, 100 * (w19 / we - 1), 100 * (z19 / ze - 1)])
    print_table("  wn [rad/s], zeta, zeta*wn [1/s]: co-simulated, and the difference of co-simulated and "
                "eq 19 from the exact fourth-order model [%]:",
                ["case", "V [m/s]", "wn", "zeta", "zeta*wn", "wn-ex%", "z-ex%", "wn eq19", "z eq19",
                 "eq19 wn%", "eq19 z%"], table,
                {2: "{:.3f}", 3: "{:.3f}", 4: "{:.3f}", 5: "{:+.2e}", 6: "{:+.2e}", 7: "{:.3f}", 8: "{:.3f}",
                 9: "{:+.1f}", 10: "{:+.1f}"})
    worst = max(v[2] for v in res["fits"].values())
    print(f"  (rational fits of the co-simulated responses: max relative residual {worst:.1e})")
    for speed in res["speeds"]:
        m = res["modes"]
        zw = {c: m[c, speed]["cosim"][0] * m[c, speed]["cosim"][1] for c in CASES}
        print(f"  {speed:.1f} m/s: zeta*wn no lag {zw['no lag']:.2f}, front lag {zw['front lag']:.2f}, "
              f"rear lag {zw['rear lag']:.2f}, both {zw['both lagged']:.2f} 1/s "
              f"(front lag {'raises' if zw['front lag'] > zw['no lag'] else 'lowers'} it, "
              f"rear lag {'raises' if zw['rear lag'] > zw['no lag'] else 'lowers'} it)")


def plot(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    speeds = np.array(res["speeds"])
    fine = np.linspace(speeds.min(), speeds.max(), 200)
    colors = {"no lag": "k", "front lag": "C0", "rear lag": "C3", "both lagged": "C2"}
    fig, axes = plt.subplots(1, 3, figsize=(15, 5), constrained_layout=True)
    quantities = (("natural frequency $f_n$ [Hz]", lambda w, z: w / (2 * math.pi)),
                  ("damping ratio ζ [1]", lambda w, z: z),
                  ("damping coefficient ζω$_n$ [1/s]", lambda w, z: z * w))
    for ax, (label, q) in zip(axes, quantities):
        for case, c in colors.items():
            t = [taus(case, v) for v in fine]
            exact = [q(*handling_mode(exact_poles(v, *tt))) for v, tt in zip(fine, t)]
            approx = [q(*eq19(v, *tt)) for v, tt in zip(fine, t)]
            cosim = [q(*res["modes"][case, v]["cosim"]) for v in speeds]
            ax.plot(fine, exact, "-", color=c, lw=1.3, label=f"{case}: exact 4th-order model")
            if case != "no lag":
                ax.plot(fine, approx, "--", color=c, lw=1, label=f"{case}: Kim eq 19")
            ax.plot(speeds, cosim, "o", color=c, ms=5, mfc="none", label=f"{case}: co-simulated (FMU)")
        ax.set_xlabel("speed V [m/s]")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7, ncol=1, loc="upper right")
    fig.suptitle(f"Handling mode of a mid-size car (Cadillac SRX data) on RLT tires, σ = {SIGMA:.2f} m: "
                 "a front lag damps it, a rear lag undamps it (Kim 2008)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write(res: dict, path: Path) -> None:
    rows = []
    for (case, speed), m in res["modes"].items():
        for source in ("cosim", "exact", "eq19"):
            wn, z = m[source]
            rows.append([case, speed, source, wn, wn / (2 * math.pi), z, z * wn])
    write_csv(path, ["case", "speed_m_per_s", "source", "wn_rad_per_s", "fn_Hz", "zeta", "zeta_wn_per_s"], rows)


def main(argv=None) -> dict:
    return run_example(__doc__.split("\n\n")[0], NAME, simulate, report, write, plot, argv)


if __name__ == "__main__":
    main()
