#!/usr/bin/env python3
"""A car parked on a slope with its engine idling: held by static friction, or sliding.

A 1500 kg car stands on a grade with all four wheels locked (parking brake on the rear
wheels, P on a front-wheel-drive gearbox) and its engine idling. The grade pulls the car
along its x axis (x points downhill), and the idling engine shakes it. The tires' friction
limit (docs/specification.md 4c) decides what happens:

* 20 % grade (11.3 deg), tan(theta) = 0.2 < mu: the tires hold the car. It settles on the
  tires' longitudinal stiffness and vibrates about a fixed position; it does not creep
  (60 s; the drift is measured over the last 30 s).
* 100 % grade (45 deg), tan(theta) = 1 > muX(Fz): the tires slide and the car accelerates
  down the slope at a = g (sin(theta) - muX(Fz) cos(theta)) (5 s).

The model:
* Body: the car's motion along the slope, m dv/dt = m g sin(theta) (1 + 0.2 sin(2 pi 25 t))
  + 4 Fx, dx/dt = v. The engine vibration is a 20 % ripple of the grade force at 25 Hz (the
  second engine order of a four-cylinder engine idling at 750 rpm), applied as a
  longitudinal force on the body; the wheel loads stay constant.
* Tires: DDT (standstill-safe and damped: at rho = 0 each direction is a spring-damper to
  the ground, docs/specification.md 4), with the Brush friction law (the FMU default) and, for comparison,
  Coulomb. Each tire gets vsx = v, the body's velocity along x: a locked wheel's slip
  velocity vx - omega Re is the velocity of the wheel centre, and omega = 0. Its vx input
  is 0: the relaxation terms of the models use rho = |vx| as the speed at which tread runs
  through the contact patch, and a locked wheel rolls no tread through it. (Fed with the
  body's few mm/s of vibration instead, those terms would relax the tire a little every
  cycle, and the parked car would creep.)
* The four wheels see the same motion and the same load (the grade's load transfer
  between the axles is neglected), so ONE TireLag instance stands for all four: it gets
  Fz = m g cos(theta) / 4 and the body feels 4 Fx. This is exact for four identical tires,
  and a quarter of the work of four instances.
* Tire parameters (a passenger-car tire, documented choices; the lateral ones are not
  excited, vy = 0): Fz0 = 4000 N, Ckappa = 80 kN (20 Fz0), sigmaX = 0.2 m, so the
  standstill stiffness is C_x = Ckappa/sigmaX = 400 kN/m per tire; dampingX = 2000 N.s/m
  (the car rocks on its tires at 5.2 Hz with a damping ratio of 0.08); muX = 0.8 at Fz0,
  muLoadSensitivity = -0.1 (FMU default), so muX(Fz) = 0.8 (1 - 0.1 (Fz/Fz0 - 1)).
* The master is cosim.CoSimulation (see cosim/coupling.py): the body stepped exactly, the
  tire input vsx ramped over each step, the implicit coupling solved by Newton iteration
  (the friction limit makes the tire nonlinear, so a step may take a third pass). 1 ms
  steps (2 ms with --quick).

Drift is measured on the displacement averaged over each 40 ms vibration period (whole
periods of the sampled ripple average to exactly 0): the slope of a straight line fitted
to those averages over the last half of the run. The sliding acceleration is
(v(T) - v(1 s))/(T - 1 s), again over whole vibration periods.

Writes out/parked_on_slope.png (displacement and its period averages while held; the
velocity while sliding against the physics; the tire force over its limit) and
out/parked_on_slope.csv (one row per 40 ms vibration period and run: case, friction law,
period start [s], mean/min/max displacement [m], mean velocity [m/s], mean/min/max Fx
of one tire [N], muX(Fz) Fz [N]).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cosim import CoSimulation, TireLag, load_fmu  # noqa: E402
from cosim.cli import print_table, run_example, write_csv  # noqa: E402

NAME = "parked_on_slope"
G = 9.81
MASS = 1500.0                     # kg
WHEELS = 4
RIPPLE = 0.2                      # of the grade force
RIPPLE_HZ = 25.0                  # Hz
LAWS = ("Brush", "Coulomb")
CASES = {"holds": 0.20, "slides": 1.00}       # grade tan(theta)
TIRE = {"Fz0": 4000.0, "Ckappa": 80000.0, "sigmaX": 0.2, "dampingX": 2000.0,
        "muX": 0.8, "muY": 0.8, "muLoadSensitivity": -0.1}
SLIDE_FROM = 1.0                  # s: the sliding acceleration is measured from here on


def settings(quick: bool) -> dict:
    if quick:
        return {"h": 0.002, "holds": 10.0, "slides": 2.0}
    return {"h": 0.001, "holds": 60.0, "slides": 5.0}


def mu_at(mu: float, Fz: float, Fz0: float, sensitivity: float) -> float:
    """docs/specification.md 4c: mu(Fz) = mu (1 + muLoadSensitivity (Fz/Fz0 - 1)), never below 0."""
    return max(0.0, mu * (1.0 + sensitivity * (Fz / Fz0 - 1.0)))


class ParkedCar:
    """The car's motion along the slope on one TireLag instance standing for its four
    locked wheels (see the module doc). States x [m] (downhill), v [m/s]; external input
    drive [N], the downhill force on the body (grade force with the engine ripple)."""

    state_names = ("x", "v")
    external_names = ("drive",)

    def __init__(self, tire: TireLag, wheel_load: float, mass: float = MASS, wheels: int = WHEELS):
        self.tires = {"wheel": tire}
        self.wheel_load = float(wheel_load)
        self.mass = float(mass)
        self.wheels = wheels

    def fixed_tire_inputs(self):
        # locked wheels: nothing rolls through the contact patch (vx = 0), no side slip
        return {"wheel": {"vx": 0.0, "vy": 0.0, "steerRate": 0.0, "Fz": self.wheel_load}}

    def tire_inputs(self, x, tire, ext, ext_rate):
        return {"wheel": {"vsx": x["v"]}}      # omega = 0: the slip velocity is the body's

    def derivatives(self, x, tire, tire_rate, ext, ext_rate):
        return [x["v"], (ext["drive"] + self.wheels * tire["wheel"]["Fx"]) / self.mass]

    def close(self):
        self.tires["wheel"].close()


def run(fmu, law: str, grade: float, duration: float, h: float) -> dict:
    theta = math.atan(grade)
    Fz = MASS * G * math.cos(theta) / WHEELS
    tire = TireLag(fmu, "DDT", TIRE, name=f"car-{law}-{grade}", inputs=("vsx",),
                   outputs=("Fx", "deflX"), friction=law)
    car = ParkedCar(tire, Fz)
    try:
        sim = CoSimulation(car, h)
        N = int(round(duration / h))
        t = np.arange(N + 1) * h
        drive = MASS * G * math.sin(theta) * (1.0 + RIPPLE * np.sin(2 * math.pi * RIPPLE_HZ * t))
        traj = sim.run(drive)
    finally:
        car.close()
    p = fmu.parameters(**TIRE)
    mu = mu_at(p["muX"], Fz, p["Fz0"], p["muLoadSensitivity"])
    return {"t": t, "x": traj.state("x"), "v": traj.state("v"), "Fx": traj.output("wheel", "Fx"),
            "deflX": traj.output("wheel", "deflX"),
            "drive": drive, "theta": theta, "Fz": Fz, "mu": mu, "Fmax": mu * Fz,
            "iterations": traj.iterations}


def period_means(t: np.ndarray, y: np.ndarray, h: float):
    """(start times, means, minima, maxima) of y over each whole vibration period."""
    P = int(round(1.0 / (RIPPLE_HZ * h)))
    K = (len(y) - 1) // P
    blocks = y[:K * P].reshape(K, P)
    return t[:K * P:P], blocks.mean(axis=1), blocks.min(axis=1), blocks.max(axis=1)


def simulate(fmu_path, quick: bool = False) -> dict:
    fmu = load_fmu(fmu_path)
    s = settings(quick)
    h = s["h"]
    runs, hold, slide = {}, {}, {}
    for case, grade in CASES.items():
        for law in LAWS:
            runs[case, law] = r = run(fmu, law, grade, s[case], h)
            t = r["t"]
            if case == "holds":
                t0, xm, _, _ = period_means(t, r["x"], h)
                _, um, _, _ = period_means(t, r["deflX"], h)
                tail = t0 >= t[-1] / 2                            # the last half of the run
                mid = t0[tail] + 0.5 / RIPPLE_HZ
                in_tail = t >= t[-1] / 2
                hold[law] = {
                    "slope": float(np.polyfit(mid, xm[tail], 1)[0]),
                    "mean_change": float(xm[tail][-1] - xm[tail][0]),
                    "mean_range": float(np.ptp(xm[tail])),
                    "x_mean": float(xm[tail][-1]),
                    "deflX_mean": float(um[tail][-1]),
                    "x_peak_to_peak": float(np.ptp(r["x"][in_tail])),
                    "utilisation": float(np.max(np.abs(r["Fx"])) / r["Fmax"]),
                    "tail_seconds": float(t[-1] - t[-1] / 2),
                }
            else:
                i1 = int(round(SLIDE_FROM / h))
                a_phys = G * (math.sin(r["theta"]) - r["mu"] * math.cos(r["theta"]))
                at_limit = np.abs(r["Fx"]) >= r["Fmax"] * (1.0 - 1e-9)
                # the tire slides from the first sample after which it stays on its limit
                start = len(at_limit) - int(np.argmin(at_limit[::-1])) if not at_limit.all() else 0
                slide[law] = {
                    "a": float((r["v"][-1] - r["v"][i1]) / (t[-1] - t[i1])),
                    "a_physics": a_phys,
                    "slide_start": float(t[min(start, len(t) - 1)]),
                    "Fx_over_Fmax": (float(r["Fx"][i1:].min() / r["Fmax"]),
                                     float(r["Fx"][i1:].max() / r["Fmax"])),
                }
    hold_run = runs["holds", LAWS[0]]
    C_x = TIRE["Ckappa"] / TIRE["sigmaX"]
    return {
        "h": h, "runs": runs, "hold": hold, "slide": slide, "C_x": C_x,
        "static_deflection": MASS * G * math.sin(hold_run["theta"]) / (WHEELS * C_x),
        "grades": dict(CASES),
        "Fz": {case: runs[case, LAWS[0]]["Fz"] for case in CASES},
        "mu": {case: runs[case, LAWS[0]]["mu"] for case in CASES},
        "Fmax": {case: runs[case, LAWS[0]]["Fmax"] for case in CASES},
        "durations": {case: s[case] for case in CASES},
    }


def report(res: dict) -> None:
    print(f"A {MASS:g} kg car parked on a slope, four locked wheels (one DDT TireLag instance x 4), "
          f"engine ripple {RIPPLE:.0%} of the grade force at {RIPPLE_HZ:g} Hz")
    for case, grade in res["grades"].items():
        theta = math.degrees(math.atan(grade))
        print(f"  {case}: grade {grade:.0%} ({theta:.2f} deg), Fz = {res['Fz'][case]:.1f} N per wheel, "
              f"muX(Fz) = {res['mu'][case]:.5f}, tan(theta) {'<' if grade < res['mu'][case] else '>'} muX(Fz), "
              f"{res['durations'][case]:g} s")
    rows = []
    for law, r in res["hold"].items():
        rows.append([law, r["x_mean"] * 1e3, r["deflX_mean"] * 1e3, r["x_peak_to_peak"] * 1e6, r["slope"],
                     r["mean_change"] * 1e6, r["utilisation"]])
    print_table(f"  holds (last {res['hold'][LAWS[0]]['tail_seconds']:g} s; x averaged over each vibration period):",
                ["law", "x [mm]", "deflX [mm]", "x p-p [um]", "drift slope [m/s]", "mean change [um]",
                 "max |Fx|/Fmax"], rows,
                {1: "{:.6f}", 2: "{:.6f}", 3: "{:.2f}", 4: "{:+.2e}", 5: "{:+.2e}", 6: "{:.3f}"})
    print(f"    deflX (elastic, period mean) = static deflection m g sin(theta)/(4 C_x) = "
          f"{res['static_deflection'] * 1e3:.6f} mm (C_x = {res['C_x'] / 1e3:g} kN/m) for both laws.\n"
          f"    Coulomb sticks throughout: x = deflX + h^2/12 g sin(theta) = +"
          f"{res['h'] ** 2 / 12 * G * math.sin(math.atan(res['grades']['holds'])) * 1e6:.2f} um (the master "
          f"ramps the velocity over the first step, when the load comes on at once).\n"
          f"    Brush sits {(res['hold']['Brush']['x_mean'] - res['hold']['Brush']['deflX_mean']) * 1e3:.3f} mm "
          f"further down: its weaker branches slid while the car settled, then held.")
    rows = []
    for law, r in res["slide"].items():
        rows.append([law, r["a"], r["a_physics"], r["a"] / r["a_physics"] - 1.0, r["slide_start"],
                     f"{r['Fx_over_Fmax'][0]:.9f} .. {r['Fx_over_Fmax'][1]:.9f}"])
    print_table(f"  slides (acceleration from {SLIDE_FROM:g} s; physics a = g (sin(theta) - muX(Fz) cos(theta))):",
                ["law", "a [m/s2]", "physics [m/s2]", "rel. diff", "sliding from [s]", "Fx/Fmax"], rows,
                {1: "{:.9f}", 2: "{:.9f}", 3: "{:+.1e}", 4: "{:.3f}"})


def plot(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colors = {"Brush": "C2", "Coulomb": "C3"}
    h = res["h"]
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5), constrained_layout=True)
    ax_x, ax_d = axes[0]
    ax_v, ax_f = axes[1]
    for law in LAWS:
        r = res["runs"]["holds", law]
        t0, xm, xlo, xhi = period_means(r["t"], r["x"], h)
        ax_x.plot(r["t"], r["x"] * 1e3, color=colors[law], lw=0.4, alpha=0.6,
                  label=f"{law}: displacement (with the 25 Hz vibration)")
        ax_x.plot(t0 + 0.5 / RIPPLE_HZ, xm * 1e3, color=colors[law], lw=1.5, ls="--",
                  label=f"{law}: mean over each vibration period")
        tail = t0 >= r["t"][-1] / 2
        hr = res["hold"][law]
        ref = xm[tail][0]
        ax_d.fill_between(t0[tail] + 0.5 / RIPPLE_HZ, (xlo[tail] - ref) * 1e6, (xhi[tail] - ref) * 1e6,
                          color=colors[law], alpha=0.15, lw=0, label=f"{law}: range of the vibration")
        ax_d.plot(t0[tail] + 0.5 / RIPPLE_HZ, (xm[tail] - xm[tail][0]) * 1e6, color=colors[law], lw=2.0,
                  ls="-" if law == "Brush" else "--",
                  label=f"{law}: period mean, fitted drift {hr['slope']:+.1e} m/s")
    ax_x.axhline(res["static_deflection"] * 1e3, color="0.4", ls=":", lw=1,
                 label="linear static deflection m g sinθ / (4 C_x)")
    ax_x.set_xlabel("time [s]")
    ax_x.set_ylabel("displacement down the slope x [mm]")
    ax_x.set_xlim(0.0, 3.0)
    ax_x.set_title(f"{res['grades']['holds']:.0%} grade: the car settles on its tires (first 3 s)")
    ax_x.legend(fontsize=8, loc="lower right")
    ax_d.set_xlabel("time [s]")
    ax_d.set_ylabel("displacement change from the first period mean [µm]")
    ax_d.set_title(f"{res['grades']['holds']:.0%} grade: no creep over the last half of the run")
    half = max(res["hold"][law]["x_peak_to_peak"] for law in LAWS) / 2 * 1e6
    ax_d.set_ylim(-1.8 * half, 1.8 * half)
    ax_d.legend(fontsize=8, loc="upper right")

    for law in LAWS:
        r = res["runs"]["slides", law]
        ax_v.plot(r["t"], r["v"], color=colors[law], lw=1.5 if law == "Brush" else 1.0,
                  ls="-" if law == "Brush" else "--", label=f"{law}: co-simulated")
    r = res["runs"]["slides", LAWS[0]]
    sl = res["slide"][LAWS[0]]
    i1 = int(round(SLIDE_FROM / h))
    ax_v.plot(r["t"][i1:], r["v"][i1] + sl["a_physics"] * (r["t"][i1:] - r["t"][i1]), color="k", lw=0.8, ls=":",
              label=f"physics: a = g (sinθ − μx(Fz) cosθ) = {sl['a_physics']:.4f} m/s²")
    ax_v.set_xlabel("time [s]")
    ax_v.set_ylabel("velocity down the slope v [m/s]")
    ax_v.set_title(f"{res['grades']['slides']:.0%} grade: the tires slide")
    ax_v.legend(fontsize=8, loc="upper left")

    for case, ls in (("holds", "-"), ("slides", "-")):
        for law in LAWS:
            r = res["runs"][case, law]
            ax_f.plot(r["t"], r["Fx"] / r["Fmax"], color=colors[law], lw=0.5 if case == "holds" else 1.2,
                      ls=ls if law == "Brush" else "--", alpha=0.8,
                      label=f"{law}, {res['grades'][case]:.0%} grade")
    ax_f.axhline(-1.0, color="0.4", ls=":", lw=1, label="friction limit −μx(Fz) Fz")
    ax_f.text(2.5, -0.2, f"{res['grades']['holds']:.0%} grade: held", ha="center", fontsize=9)
    ax_f.text(2.5, -0.95, f"{res['grades']['slides']:.0%} grade: sliding, on the limit", ha="center", fontsize=9)
    ax_f.set_xlim(0, res["durations"]["slides"])
    ax_f.set_ylim(-1.15, 0.1)
    ax_f.set_xlabel("time [s]")
    ax_f.set_ylabel("tire force Fx / (μx(Fz) Fz) [1]")
    ax_f.set_title("Tire force against its limit (first seconds)")
    ax_f.legend(fontsize=8, loc="center right")
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"A {MASS:g} kg car parked on a slope, wheels locked, engine idling (20 % force ripple at "
                 f"{RIPPLE_HZ:g} Hz): DDT tires with Brush and Coulomb friction")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write(res: dict, path: Path) -> None:
    h = res["h"]
    rows = []
    for (case, law), r in res["runs"].items():
        t0, xm, xmin, xmax = period_means(r["t"], r["x"], h)
        _, vm, _, _ = period_means(r["t"], r["v"], h)
        _, fm, fmin, fmax = period_means(r["t"], r["Fx"], h)
        for i in range(len(t0)):
            rows.append([case, law, float(t0[i]), float(xm[i]), float(xmin[i]), float(xmax[i]), float(vm[i]),
                         float(fm[i]), float(fmin[i]), float(fmax[i]), float(r["Fmax"])])
    write_csv(path, ["case", "friction", "period_start_s", "x_mean_m", "x_min_m", "x_max_m", "v_mean_m_per_s",
                     "Fx_mean_N", "Fx_min_N", "Fx_max_N", "Fx_limit_N"], rows)


def main(argv=None) -> dict:
    return run_example(__doc__.split("\n\n")[0], NAME, simulate, report, write, plot, argv)


if __name__ == "__main__":
    main()
