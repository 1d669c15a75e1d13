#!/usr/bin/env python3
"""Wheel loader steered at standstill: the tire's torque-angle loop, with and without friction.

The Aalborg thesis (docs/specification.md 9) measured a 17.6 t wheel loader on 23.5R25 tires in a
0.2 Hz, +-40 deg snake steering test, and identified the tire's torsional stiffness at
45000 N.m/rad and its damping at 400 N.m.s/rad. This script twists one such tire about its
vertical axis at standstill: one TireLag instance (DDT) with vx = vy = 0 and the steer angle

    delta(t) = 40 deg sin(2 pi 0.2 t),    steerRate = d(delta)/dt,

given at every communication point with its rate (fmi2SetRealInputDerivatives), so the
FMU steps the piecewise linear steer rate exactly. At rho = 0 the DDT yaw lag is a
spring-damper on the steer angle (docs/specification.md 4): duPsi/dt = r, Mz = -(C_yaw uPsi + D_yaw r)
(vy = 0 keeps Fy, and so the trail term, at zero). It is run with the three friction
laws of docs/specification.md 4c:

* Unlimited: an elastic loop, peak |Mz| = A sqrt(C_yaw^2 + (D_yaw w)^2) = 31.4 kN.m
  (A = 40 deg = 0.698 rad, w = 2 pi 0.2 Hz), and the energy the steering puts into the
  tire per cycle is the damper's, pi D_yaw w A^2.
* Coulomb: the yaw moment is linear up to boreRadius muY(Fz) Fz and flat beyond: the loop
  becomes a parallelogram whose area is the energy the contact patch dissipates by
  scrubbing on the ground.
* Brush: four branches that slide one after the other round off the corners of the loop;
  with +-40 deg every branch slides, so the plateau is the same.

Load and bore radius (both documented choices, not from the thesis):
* Wheel load: the 17.6 t machine's weight shared by its four tires, Fz = 17600 * 9.81 / 4
  = 43.2 kN. The nominal load Fz0 stays at the FMU's default, 50 kN, where muY = 0.8;
  with muLoadSensitivity = -0.1 the friction coefficient at 43.2 kN is
  muY(Fz) = 0.8 (1 - 0.1 (43.2/50 - 1)) = 0.811.
* Bore radius: the lever arm of the friction moment, boreRadius muY Fz, is the mean
  distance of the contact points from the centre of the footprint under uniform
  pressure. The footprint of a 23.5R25 (section width 0.60 m) at 43 kN is taken as a
  rectangle 0.45 m wide and 0.30 m long (0.135 m2, a mean ground pressure of 320 kPa,
  about the inflation pressure of such a tire); its mean distance from the centre is
  0.1452 m (closed form in ``bore_radius``). The plateau is then 5.08 kN.m, a sixth of the
  elastic peak: at +-40 deg the real tire scrubs over most of the stroke.

Writes out/wheel_loader_steering.png (Mz against the steer angle over the last cycle for
the three laws; Mz over time) and out/wheel_loader_steering.csv (time [s], steer angle
[rad], steer rate [rad/s], then Mz [N.m] and deflPsi [rad] for each law).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cosim import TireLag, load_fmu  # noqa: E402
from cosim.cli import print_table, run_example, write_csv  # noqa: E402

NAME = "wheel_loader_steering"
LAWS = ("Unlimited", "Coulomb", "Brush")
G = 9.81
MACHINE_MASS = 17600.0                         # kg (docs/specification.md 9)
WHEEL_LOAD = MACHINE_MASS * G / 4.0            # N, per tire
STIFFNESS_PSI = 45000.0                        # N.m/rad (docs/specification.md 9)
DAMPING_PSI = 400.0                            # N.m.s/rad (docs/specification.md 9)
STEER_AMPLITUDE = math.radians(40.0)           # rad
STEER_FREQUENCY = 0.2                          # Hz
FOOTPRINT = (0.45, 0.30)                       # m, width x length of the contact patch (see above)


def bore_radius(width: float, length: float) -> float:
    """Mean distance from the centre of a width x length rectangle (uniform pressure):
    the lever arm of the friction moment of a patch that scrubs about its centre,
    M = mu Fz * mean(r). With half-sides a, b and d = sqrt(a^2 + b^2),
    int_0^a int_0^b r = (2 a b d + a^3 ln((b + d)/a) + b^3 ln((a + d)/b)) / 6."""
    a, b = width / 2.0, length / 2.0
    d = math.hypot(a, b)
    integral = (2 * a * b * d + a ** 3 * math.log((b + d) / a) + b ** 3 * math.log((a + d) / b)) / 6.0
    return integral / (a * b)


def mu_at(mu: float, Fz: float, Fz0: float, sensitivity: float) -> float:
    """docs/specification.md 4c: mu(Fz) = mu (1 + muLoadSensitivity (Fz/Fz0 - 1)), never below 0."""
    return max(0.0, mu * (1.0 + sensitivity * (Fz / Fz0 - 1.0)))


def settings(quick: bool) -> dict:
    if quick:
        return {"h": 0.005, "cycles": 2}
    return {"h": 0.001, "cycles": 3}


def loop_energy(steer: np.ndarray, Mz: np.ndarray) -> float:
    """Energy the steering puts into the tire over one closed cycle, -closed integral of
    Mz d(delta) (Mz is the tire's moment on the hub, so the steering works against it);
    trapezoids in delta. Positive: the tire dissipates."""
    return float(-np.sum(0.5 * (Mz[1:] + Mz[:-1]) * np.diff(steer)))


def simulate(fmu_path, quick: bool = False) -> dict:
    fmu = load_fmu(fmu_path)
    s = settings(quick)
    h = s["h"]
    period = 1.0 / STEER_FREQUENCY
    P = int(round(period / h))
    N = s["cycles"] * P
    t = np.arange(N + 1) * h
    omega = 2 * math.pi * STEER_FREQUENCY
    steer = STEER_AMPLITUDE * np.sin(omega * t)
    rate = STEER_AMPLITUDE * omega * np.cos(omega * t)
    rb = bore_radius(*FOOTPRINT)
    params = {"stiffnessPsi": STIFFNESS_PSI, "dampingPsi": DAMPING_PSI, "boreRadius": rb}
    defaults = fmu.parameters(**params)
    mu = mu_at(defaults["muY"], WHEEL_LOAD, defaults["Fz0"], defaults["muLoadSensitivity"])
    plateau = rb * mu * WHEEL_LOAD
    Mz, defl = {}, {}
    for law in LAWS:
        with TireLag(fmu, "DDT", params, name=f"loader-{law}", inputs=("steerRate",),
                     outputs=("Mz", "deflPsi", "Fy"), friction=law) as tire:
            tire.set_inputs(vx=0.0, vy=0.0, vsx=0.0, Fz=WHEEL_LOAD)
            Y = np.empty((N + 1, 3))
            Y[0] = tire.begin_step(rate[:1])
            for k in range(N):
                tire.begin_step(rate[k:k + 1])
                Y[k + 1] = tire.advance(h, rate[k:k + 1], rate[k + 1:k + 2])
        if np.any(Y[:, 2] != 0.0):
            raise RuntimeError(f"{law}: Fy should stay 0 with vx = vy = 0")
        Mz[law], defl[law] = Y[:, 0], Y[:, 1]
    last = slice(N - P, N + 1)                      # the last full cycle (periodic by then)
    results = {}
    for law in LAWS:
        results[law] = {
            "peak": float(np.max(np.abs(Mz[law][last]))),
            "energy": loop_energy(steer[last], Mz[law][last]),
        }
    return {
        "h": h, "t": t, "steer": steer, "rate": rate, "Mz": Mz, "deflPsi": defl, "last": last,
        "results": results, "bore_radius": rb, "mu": mu, "Fz": WHEEL_LOAD, "Fz0": defaults["Fz0"],
        "muY": defaults["muY"], "muLoadSensitivity": defaults["muLoadSensitivity"],
        "plateau": plateau, "omega": omega, "amplitude": STEER_AMPLITUDE,
        "elastic_peak": STEER_AMPLITUDE * math.hypot(STIFFNESS_PSI, DAMPING_PSI * omega),
        "damper_energy": math.pi * DAMPING_PSI * omega * STEER_AMPLITUDE ** 2,
        # the loop of a rigid-plastic slider on a spring (no damper): 4 M (A - M/C)
        "elastic_plastic_energy": 4 * plateau * (STEER_AMPLITUDE - plateau / STIFFNESS_PSI),
    }


def report(res: dict) -> None:
    r = res["results"]
    print(f"Wheel loader tire steered at standstill (23.5R25, 17.6 t; C_yaw {STIFFNESS_PSI:g} N.m/rad, "
          f"D_yaw {DAMPING_PSI:g} N.m.s/rad), +-40 deg at {STEER_FREQUENCY} Hz, DDT, vx = vy = 0")
    print(f"  wheel load Fz = {res['Fz'] / 1e3:.2f} kN (17.6 t / 4), Fz0 = {res['Fz0'] / 1e3:g} kN, "
          f"muY(Fz) = {res['mu']:.4f}, bore radius {res['bore_radius']:.4f} m "
          f"(footprint {FOOTPRINT[0]} m x {FOOTPRINT[1]} m)")
    print(f"  friction plateau boreRadius muY(Fz) Fz = {res['plateau'] / 1e3:.4f} kN.m; "
          f"elastic travel between the plateaus 2 M/C_yaw = "
          f"{math.degrees(2 * res['plateau'] / STIFFNESS_PSI):.2f} deg")
    rows = []
    expected = {"Unlimited": (res["elastic_peak"], res["damper_energy"]),
                "Coulomb": (res["plateau"], None), "Brush": (res["plateau"], None)}
    for law in LAWS:
        peak_ref, energy_ref = expected[law]
        rows.append([law, r[law]["peak"] / 1e3, peak_ref / 1e3, r[law]["peak"] / peak_ref - 1.0,
                     r[law]["energy"] / 1e3,
                     "" if energy_ref is None else f"{energy_ref / 1e3:.6f}",
                     "" if energy_ref is None else f"{r[law]['energy'] / energy_ref - 1.0:+.1e}"])
    print_table("  peak |Mz| and energy dissipated per cycle (last cycle):",
                ["law", "peak [kN.m]", "expected [kN.m]", "rel. diff", "energy [kJ]",
                 "pi D w A^2 [kJ]", "rel. diff"], rows,
                {1: "{:.4f}", 2: "{:.4f}", 3: "{:+.1e}", 4: "{:.6f}"})
    print(f"  (Unlimited expected peak A sqrt(C^2 + (D w)^2); 45000 N.m/rad x 40 deg = "
          f"{STIFFNESS_PSI * STEER_AMPLITUDE / 1e3:.2f} kN.m. Coulomb loop against an "
          f"elastic-plastic loop without damper, 4 M (A - M/C) = {res['elastic_plastic_energy'] / 1e3:.3f} kJ)")


def plot(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    styles = {"Unlimited": ("C0", "-"), "Coulomb": ("C3", "-"), "Brush": ("C2", "--")}
    last = res["last"]
    fig, (ax_l, ax_t) = plt.subplots(1, 2, figsize=(13, 5.5), constrained_layout=True)
    steer_deg = np.degrees(res["steer"])
    for law in LAWS:
        color, ls = styles[law]
        r = res["results"][law]
        ax_l.plot(steer_deg[last], res["Mz"][law][last] / 1e3, color=color, ls=ls, lw=1.6,
                  label=f"{law}: peak {r['peak'] / 1e3:.2f} kN.m, {r['energy'] / 1e3:.2f} kJ/cycle")
        ax_t.plot(res["t"], res["Mz"][law] / 1e3, color=color, ls=ls, lw=1.2, label=law)
    for ax in (ax_l, ax_t):
        for sign in (1, -1):
            ax.axhline(sign * res["plateau"] / 1e3, color="0.4", ls=":", lw=1,
                       label=(f"±boreRadius·muY(Fz)·Fz = ±{res['plateau'] / 1e3:.2f} kN.m"
                              if sign > 0 else None))
        ax.grid(True, alpha=0.3)
    ax_l.set_xlabel("steer angle δ [deg]")
    ax_l.set_ylabel("tire yaw moment on the hub Mz [kN.m]")
    ax_l.set_title("Torque-angle loops (last cycle)")
    ax_l.legend(fontsize=8, loc="upper right")
    ax_t.set_xlabel("time [s]")
    ax_t.set_ylabel("tire yaw moment on the hub Mz [kN.m]")
    ax_t.set_title("Mz over the run (steer angle: right axis)")
    ax_s = ax_t.twinx()
    ax_s.plot(res["t"], steer_deg, color="k", lw=0.8, alpha=0.5, label="steer angle δ")
    ax_s.set_ylabel("steer angle δ [deg]")
    # headroom for the legend, with 0 at the same height on both axes
    top = res["elastic_peak"] / 1e3
    ax_t.set_ylim(-1.15 * top, 1.7 * top)
    ax_s.set_ylim(-1.15 * 40.0, 1.7 * 40.0)
    ax_s.set_yticks([-40, -20, 0, 20, 40])
    lines, labels = ax_t.get_legend_handles_labels()
    lines2, labels2 = ax_s.get_legend_handles_labels()
    ax_t.legend(lines + lines2, labels + labels2, fontsize=8, loc="upper center", ncol=2)
    fig.suptitle(f"Wheel loader tire (23.5R25, Fz = {res['Fz'] / 1e3:.1f} kN) twisted ±40° at 0.2 Hz "
                 "at standstill: DDT yaw spring-damper without and with the friction limit")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write(res: dict, path: Path) -> None:
    header = ["time_s", "steer_angle_rad", "steer_rate_rad_per_s"]
    for law in LAWS:
        header += [f"Mz_{law}_Nm", f"deflPsi_{law}_rad"]
    cols = [res["t"], res["steer"], res["rate"]]
    for law in LAWS:
        cols += [res["Mz"][law], res["deflPsi"][law]]
    rows = ([float(c[i]) for c in cols] for i in range(len(res["t"])))
    write_csv(path, header, rows)


def main(argv=None) -> dict:
    return run_example(__doc__.split("\n\n")[0], NAME, simulate, report, write, plot, argv)


if __name__ == "__main__":
    main()
