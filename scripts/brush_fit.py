#!/usr/bin/env python3
"""Derive the four-branch fit of the `Brush` friction law (docs/specification.md 4c).

Each contact element is split into four parallel branches i = 1..4: a spring with the
fraction w_i of the element's stiffness in series with a Coulomb slider whose limit is
the fraction phi_i of the element's friction limit Fmax (sum w_i = sum phi_i = 1). In
steady rolling at slip angle alpha branch i carries min(w_i Calpha |alpha|, phi_i Fmax),
so with x = Calpha |alpha| / Fmax

    F(x) / Fmax = sum_i min(w_i x, phi_i),

a concave piecewise-linear curve with breakpoints x_i = phi_i / w_i: F = x up to the
smallest breakpoint, F = 1 beyond the largest. The target is the brush curve

    b(x) = 3 t - 3 t^2 + t^3 = 1 - (1 - t)^3,   t = min(1, x / 3).

Requirements: |F - b| <= 0.02 for all x >= 0, and F exactly linear below 0.2, i.e.
min_i x_i >= 0.2.

Parametrisation. Take the breakpoints x1 < x2 < x3 < x4 and the values of F at the
inner two, y2 = F(x2), y3 = F(x3); F(x1) = x1 and F(x4) = 1 are fixed by the structure.
The slopes of F between breakpoints are s0 = 1, s1, s2, s3, s4 = 0, and branch i stops
contributing slope at x_i, so w_i = s_{i-1} - s_i; continuity (branch i reaches its limit
exactly at x_i) gives phi_i = w_i x_i. Then sum w_i = s0 - s4 = 1 and
sum phi_i = sum w_i x_i = F(x4) = 1 (summation by parts), so both sums hold by
construction, and w_i > 0 is F being strictly concave.

Where the error can peak. b is concave, so on each linear piece the error e = F - b is
convex: its maxima are at the breakpoints and its one minimum is where b'(x) = slope,
b'(x) = (1 - x/3)^2, i.e. at x = 3 (1 - sqrt(s)). On [0, x1] (F = x) the error grows from
0 to e(x1); beyond x4 (F = 1) it falls from e(x4) to 0 at x = 3. So the maximum error is
the largest of |e| at seven points: +e(x1), -e(tangent 1), +e(x2), -e(tangent 2),
+e(x3), -e(tangent 3), +e(x4). These are computed exactly; a dense grid is only used to
check.

The optimum. Without the linearity constraint the minimax fit equalises all seven
extrema at 0.01186 with x1 = 0.1907 < 0.2, so the constraint binds: x1 = 0.2 exactly,
and the error there, 0.2 - b(0.2) = 0.0130370..., is a lower bound that no fit with
x1 >= 0.2 can beat (F = x on [0, 0.2] regardless). That is the achieved maximum error,
at x = 0.2. The remaining five unknowns (x2, x3, x4, y2, y3) are chosen so that the
other six extrema are as small as possible (they equioscillate at a level E2 < 0.01304):
first SLSQP on the epigraph form from a fixed start, then polished by solving the six
equioscillation equations with fsolve. Everything is deterministic.

Run from the repository root:

    .venv/bin/python scripts/brush_fit.py [--plot out/brush_fit.png] [--no-plot]
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
from scipy.optimize import fsolve, minimize

X_LINEAR = 0.2  # F must equal x (all branches sticking) for x <= X_LINEAR
TOLERANCE = 0.02  # required max |F - b|
X1 = X_LINEAR  # the binding constraint: the smallest breakpoint sits exactly on it


def brush(x):
    """The brush curve b(x) = 3t - 3t^2 + t^3, t = min(1, x/3), for x >= 0."""
    t = np.minimum(1.0, np.asarray(x, dtype=float) / 3.0)
    return 3.0 * t - 3.0 * t**2 + t**3


def tangent_point(slope):
    """The x where b'(x) = (1 - x/3)^2 equals `slope` (0 < slope <= 1)."""
    return 3.0 * (1.0 - np.sqrt(slope))


def branches(knots, values):
    """Breakpoints x1..x4 and F there -> (w, phi): slopes give w, continuity gives phi."""
    x = np.asarray(knots, dtype=float)
    f = np.asarray(values, dtype=float)
    slopes = np.empty(5)
    slopes[0] = 1.0  # all branches stick: F = x
    slopes[1:4] = np.diff(f) / np.diff(x)
    slopes[4] = 0.0  # all branches slide: F = 1
    w = slopes[:-1] - slopes[1:]
    phi = w * x
    return w, phi


def force_fraction(x, w, phi):
    """Steady-state F(x)/Fmax = sum_i min(w_i x, phi_i) for x >= 0."""
    x = np.asarray(x, dtype=float)
    return sum(np.minimum(wi * x, pi) for wi, pi in zip(w, phi))


def unpack(p):
    """Free parameters (x2, x3, x4, y2, y3) -> breakpoints and F at them (x1 = 0.2)."""
    x2, x3, x4, y2, y3 = p
    return np.array([X1, x2, x3, x4]), np.array([X1, y2, y3, 1.0])


def extrema(knots, values):
    """The error F - b at its local extrema beyond x1: (x, e) at tangent 1, x2, tangent 2,
    x3, tangent 3, x4 (the signs alternate -, +, -, +, -, +)."""
    xs, es = [], []
    for k in range(3):  # the three sloped pieces between x1 and x4
        s = (values[k + 1] - values[k]) / (knots[k + 1] - knots[k])
        xt = tangent_point(s)
        xs += [xt, knots[k + 1]]
        es += [values[k] + s * (xt - knots[k]) - brush(xt), values[k + 1] - brush(knots[k + 1])]
    return np.array(xs), np.array(es)


def fit():
    """The five free parameters (x2, x3, x4, y2, y3) and the inner level E2."""
    signs = np.array([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0])

    # 1. Epigraph form: minimise E2 subject to |e_j| <= E2 at the six inner extrema,
    #    with the breakpoints ordered and F strictly concave. Fixed start.
    start = np.array([0.8, 1.5, 2.4, 0.6, 0.87, 0.015])  # x2, x3, x4, y2, y3, E2

    def inner_errors(q):
        return extrema(*unpack(q[:5]))[1]

    def concavity(q):
        knots, values = unpack(q[:5])
        w, _ = branches(knots, values)
        return w - 1e-6

    constraints = [
        {"type": "ineq", "fun": lambda q: q[5] - signs * inner_errors(q)},  # signed side
        {"type": "ineq", "fun": lambda q: q[5] + signs * inner_errors(q)},
        {"type": "ineq", "fun": lambda q: np.diff(np.r_[X1, q[:3]]) - 1e-3},
        {"type": "ineq", "fun": concavity},
    ]
    res = minimize(lambda q: q[5], start, method="SLSQP", constraints=constraints,
                   options={"ftol": 1e-14, "maxiter": 500})
    if not res.success:
        sys.exit(f"SLSQP failed: {res.message}")

    # 2. Polish: the six inner extrema equioscillate, signs * e_j = E2.
    def equioscillation(q):
        return signs * inner_errors(q) - q[5]

    q, info, ier, msg = fsolve(equioscillation, res.x, xtol=1e-13, full_output=True)
    if np.max(np.abs(equioscillation(q))) > 1e-15:
        sys.exit(f"fsolve failed: {msg}")
    if not np.allclose(q, res.x, rtol=0, atol=1e-6):
        sys.exit(f"SLSQP and the equioscillation solve disagree:\n{res.x}\n{q}")
    return q[:5], q[5]


def unconstrained_fit():
    """For comparison: the minimax fit without the linearity constraint (x1 free), where
    all seven extrema equioscillate. Returns (x1, level)."""
    signs = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0])

    def equations(q):
        x1, x2, x3, x4, y2, y3, level = q
        knots, values = np.array([x1, x2, x3, x4]), np.array([x1, y2, y3, 1.0])
        e = np.r_[x1 - brush(x1), extrema(knots, values)[1]]
        return signs * e - level

    q = fsolve(equations, [0.25, 0.8, 1.5, 2.4, 0.6, 0.87, 0.015], xtol=1e-13)
    return q[0], q[6]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--plot", default="out/brush_fit.png", help="PNG to write")
    parser.add_argument("--no-plot", action="store_true", help="do not write the PNG")
    args = parser.parse_args()

    p, e2 = fit()
    knots, values = unpack(p)
    w, phi = branches(knots, values)

    # The constants as the Rust module stores them (doubles, printed with 17 digits).
    # The last fractions are 1 minus the others, so the sums are 1 to rounding; the
    # first limit is exactly 0.2 * w1 as a double, so min(w1 x, phi1) = w1 x for x <= 0.2.
    w[3] = 1.0 - (w[0] + w[1] + w[2])
    phi[3] = 1.0 - (phi[0] + phi[1] + phi[2])
    phi[0] = X_LINEAR * w[0]
    while phi[0] / w[0] < X_LINEAR:  # make the quotient, too, no smaller than 0.2
        phi[0] = np.nextafter(phi[0], np.inf)

    # Checks, on the constants themselves.
    breakpoints = phi / w
    grid = np.linspace(0.0, 4.0, 4_000_001)  # step 1e-6
    err = force_fraction(grid, w, phi) - brush(grid)
    i_max = int(np.argmax(np.abs(err)))
    lin = grid[grid <= X_LINEAR]
    lin_dev = np.max(np.abs(force_fraction(lin, w, phi) - lin))
    xe, ee = extrema(knots, values)
    checks = {
        "all w_i > 0": bool(np.all(w > 0)),
        "all phi_i > 0": bool(np.all(phi > 0)),
        "|sum w - 1| <= 1e-15": abs(w.sum() - 1.0) <= 1e-15,
        "|sum phi - 1| <= 1e-15": abs(phi.sum() - 1.0) <= 1e-15,
        "min phi_i/w_i >= 0.2": bool(breakpoints.min() >= X_LINEAR),
        "phi_1 >= 0.2 w_1 (double)": bool(phi[0] >= X_LINEAR * w[0]),
        "F(x) = x to 1e-15 on [0, 0.2]": lin_dev <= 1e-15,
        "max |F - b| <= 0.02": float(np.max(np.abs(err))) <= TOLERANCE,
        "F = 1 beyond the last breakpoint": bool(
            np.all(np.abs(force_fraction(grid[grid >= breakpoints.max()], w, phi) - 1.0) <= 1e-15)),
    }

    np.set_printoptions(precision=17)
    print("Brush four-branch fit (docs/specification.md 4c): F(x)/Fmax = sum_i min(w_i x, phi_i)")
    print(f"{'i':>2} {'stiffness_fraction w_i':>24} {'limit_fraction phi_i':>24} "
          f"{'breakpoint phi_i/w_i':>24}")
    for i in range(4):
        print(f"{i + 1:>2} {w[i]:>24.17g} {phi[i]:>24.17g} {breakpoints[i]:>24.17g}")
    print(f"sum w - 1 = {w.sum() - 1.0:.3g}, sum phi - 1 = {phi.sum() - 1.0:.3g}")
    print("As Rust (the same doubles, shortest round-trip digits):")
    for i in range(4):
        print(f"    Branch {{ stiffness_fraction: {float(w[i])!r}, "
              f"limit_fraction: {float(phi[i])!r} }},")
    print(f"F(x) at the breakpoints: {', '.join(f'{v:.17g}' for v in values)}")
    print()
    print(f"max |F - b| (grid 0..4, step 1e-6) = {abs(err[i_max]):.17g} at x = {grid[i_max]:.6f}")
    print(f"  bound forced by linearity, 0.2 - b(0.2) = {X_LINEAR - brush(X_LINEAR):.17g}")
    print(f"  inner equioscillation level E2 = {e2:.17g} (the other extrema):")
    for x, e in zip(xe, ee):
        print(f"    x = {x:.6f}  F - b = {e:+.6e}")
    print(f"  max |F(x) - x| on [0, 0.2] = {lin_dev:.3g}")
    x1_free, level_free = unconstrained_fit()
    print(f"  (without the linearity constraint: max error {level_free:.6f} with smallest "
          f"breakpoint {x1_free:.6f} < 0.2, so the constraint binds)")
    print()
    for name, ok in checks.items():
        print(f"  [{'ok' if ok else 'FAIL'}] {name}")

    if not args.no_plot:
        plot(args.plot, grid, w, phi, breakpoints, err, i_max)
        print(f"\nwrote {args.plot}")

    if not all(checks.values()):
        sys.exit("some checks failed")


def plot(path, grid, w, phi, breakpoints, err, i_max):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 7), sharex=True,
                                   gridspec_kw={"height_ratios": [2, 1]})
    ax1.plot(grid, brush(grid), label="brush curve b(x)", color="C0", lw=2)
    ax1.plot(grid, force_fraction(grid, w, phi), label="four-branch fit F(x)", color="C1",
             lw=1.5, ls="--")
    ax1.plot(grid, np.minimum(grid, 1.0), label="Coulomb min(x, 1)", color="0.6", lw=1, ls=":")
    ax1.plot(breakpoints, force_fraction(breakpoints, w, phi), "o", color="C1",
             label="breakpoints x_i = phi_i / w_i")
    ax1.axvline(X_LINEAR, color="0.7", lw=0.8)
    ax1.set_ylabel("F / Fmax")
    ax1.set_ylim(0, 1.1)
    ax1.legend(loc="lower right")
    ax1.set_title("Brush friction law: four parallel spring-slider branches (docs/specification.md 4c)")
    ax1.grid(alpha=0.3)

    ax2.plot(grid, err, color="C3", label="F(x) - b(x)")
    ax2.axhline(TOLERANCE, color="k", ls="--", lw=0.8, label="+/- 0.02 requirement")
    ax2.axhline(-TOLERANCE, color="k", ls="--", lw=0.8)
    ax2.plot(grid[i_max], err[i_max], "kx",
             label=f"max |error| = {abs(err[i_max]):.5f} at x = {grid[i_max]:.3f}")
    ax2.axvline(X_LINEAR, color="0.7", lw=0.8, label="x = 0.2 (exactly linear below)")
    ax2.set_xlabel("x = Calpha |alpha| / Fmax")
    ax2.set_ylabel("error / Fmax")
    ax2.set_xlim(0, 4)
    ax2.set_ylim(-0.025, 0.025)
    ax2.legend(loc="lower right", fontsize=8)
    ax2.grid(alpha=0.3)

    fig.tight_layout()
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
