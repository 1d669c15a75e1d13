#!/usr/bin/env python3
"""Snowblower steered at standstill: yaw rate / steer angle, DDT against RLT.

Koo & Tan (2007) steered a 20.5 t snowblower that stood still and measured a yaw
resonance near 0.8 Hz: the front tires twist, their yaw moment turns the body the other
way, and the body rocks on the lateral stiffness of its tires. A tire with only a slip
lag (RLT) has no yaw moment, and at vx = 0 steering gives it no slip either, so the
model predicts nothing at all: the "null gain" of the paper. This script co-simulates the
paper's improved bicycle model on two TireLag instances (one per axle, each standing for
the two tires of the axle) and measures the frequency response with a multisine steer.

The vehicle (Table 1): M 20500 kg, I1 168250 kg.m2, l1 1.3 m, l2 2.2 m, k1 500000
N.m/rad, c1 10000 N.m.s/rad. Each tire: Calpha 350000 N/rad, sigmaY 1.0 m (so
C_lat = Calpha/sigmaY = 350000 N/m, eq 16), D_lat 9000 N.s/m, sigmaPsi 0.45 m,
C_yaw = k2/2 = 40000 N.m/rad. See cosim/vehicle.py for the equations.

How the model is assembled (eqs 18-23, 31-39, Appendix A):
* The steering imposes the steer angle delta of the front wheels relative to the body;
  the FMU gets steerRate = d(delta)/dt. The front tires' yaw moment reaches the body
  through the steering (eqs 34-35 with the steering inertia I2 neglected), so the body
  feels 2 Mz_front.
* The front and rear contact patches are tied to the wheels by the tires' lateral
  spring-dampers (the FMU's DDT), and the body is tied to the line through the contact
  patches by the yaw spring-damper k1, c1 (eq 38). That line's heading follows from the
  tire deflections: psi_body - psi_contact = (deflY_front - deflY_rear)/(l1 + l2).
* The paper drops the steering's yaw damping c2 = 2 D_yaw and the pneumatic trail from
  the vehicle model; so does this script (dampingPsi = 0, trail = 0).

Where the text extraction of the paper is garbled, the model was rebuilt from the physics
(and it then gives exactly the 0.83 Hz / 0.066 and 1.34 Hz / 0.108 of docs/specification.md 9):
* eq 37 prints C_lat^f and "+ l2" for the rear axle; the rear axle is l2 behind the
  centre of gravity, so its deflection is (ys - yu) - l2 (psi_s - psi_u), with C_lat^r.
* eq 38 prints "Flat^f l1 - Flat^f l2"; the rear force acts at -l2: Flat^f l1 - Flat^r l2.
* eq 39 prints "- k2 (delta_eff)"; with eq 23 the yaw spring acts on the tire's yaw
  deflection, Mf = -k2 (delta - delta_eff) (- c2 (d/dt), dropped).
* Appendix A prints A11 = +vr/sigma_lat; eq 31 gives -vr/sigma_lat. A67 (= k2) is missing
  from the list of entries.
* Table 1 gives k1 and k2 in "N/m" and the definitions of k1, c1 after eq 39 are
  garbled (c1 appears twice); they are yaw stiffness and damping, used here in N.m/rad
  and N.m.s/rad with the Table 1 values.

The measured response is fitted with a rational transfer function (numerator order 3,
denominator order 4: r = s psi, and psi/delta is a two-mass-spring response to the yaw
moment), whose poles give the yaw and lateral modes.

Writes out/snowblower_standstill.png (gain and phase of r/delta with the fit and the two
modes; the steer input and the yaw rate of DDT and RLT over the last period) and
out/snowblower_standstill.csv (model, frequency [Hz], gain [1/s], gain [dB], phase [deg]).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cosim import (Multisine, fit_rational, load_fmu, log_harmonics,  # noqa: E402
                   oscillatory_modes, snowblower)
from cosim.cli import run_example, write_csv  # noqa: E402
from cosim.frequency import measure_response  # noqa: E402

NAME = "snowblower_standstill"
PAPER_RESONANCE_HZ = 0.8          # Koo & Tan, section 6 and Fig 5(a): measured
TABLE1_YAW_MODE = (0.83, 0.066)   # docs/specification.md 9: the linear model of Table 1
TABLE1_LATERAL_MODE = (1.34, 0.108)
STEER_AMPLITUDE = math.radians(1.0)


def settings(quick: bool) -> dict:
    if quick:
        return {"h": 0.01, "base": 0.1, "count": 20, "settle": 20.0}
    return {"h": 0.005, "base": 0.05, "count": 40, "settle": 30.0}


def simulate(fmu_path, quick: bool = False) -> dict:
    fmu = load_fmu(fmu_path)
    s = settings(quick)
    excitation = Multisine(s["base"], log_harmonics(0.1, 3.0, s["base"], s["count"]), STEER_AMPLITUDE)
    runs = {}
    for model in ("DDT", "RLT"):
        with snowblower(fmu, model, speed=0.0) as vehicle:
            H, traj = measure_response(vehicle, s["h"], excitation, s["settle"])
        runs[model] = (H, traj)
    H_ddt = runs["DDT"][0]
    f = excitation.frequencies
    fit = fit_rational(f, H_ddt, num_order=3, den_order=4)
    modes = oscillatory_modes(fit.poles)
    if len(modes) != 2:
        raise RuntimeError(f"expected two oscillatory modes in the fit, got {modes}")
    fine = np.geomspace(f[0], f[-1], 20001)
    peak = fine[np.argmax(np.abs(fit(fine)))]
    traj_rlt = runs["RLT"][1]
    return {
        "excitation": excitation, "h": s["h"], "frequencies": f, "H": {m: runs[m][0] for m in runs},
        "trajectories": {m: runs[m][1] for m in runs}, "fit": fit,
        "peak_frequency": float(peak),
        "peak_gain_dB": float(20 * np.log10(np.abs(fit(np.array([peak])))[0])),
        "yaw_mode": (modes[0].frequency, modes[0].damping),
        "lateral_mode": (modes[1].frequency, modes[1].damping),
        "fit_residual": float(np.max(np.abs(fit(f) / H_ddt - 1.0))),
        "rlt_max_yaw_rate": float(np.max(np.abs(traj_rlt.state("r")))),
        "rlt_max_gain": float(np.max(np.abs(runs["RLT"][0]))),
    }


def report(res: dict) -> None:
    fy, zy = res["yaw_mode"]
    fl, zl = res["lateral_mode"]
    pct = lambda x, ref: 100.0 * (x / ref - 1.0)  # noqa: E731
    print("Snowblower at standstill (Koo & Tan 2007, Table 1): yaw rate / steer angle")
    print(f"  DDT resonance peak      {res['peak_frequency']:.3f} Hz   paper (measured): about "
          f"{PAPER_RESONANCE_HZ} Hz ({pct(res['peak_frequency'], PAPER_RESONANCE_HZ):+.1f} %)")
    print(f"  DDT yaw mode            {fy:.3f} Hz, damping ratio {zy:.4f}   Table 1 linear model: "
          f"{TABLE1_YAW_MODE[0]} Hz, {TABLE1_YAW_MODE[1]} ({pct(fy, TABLE1_YAW_MODE[0]):+.1f} %, "
          f"{pct(zy, TABLE1_YAW_MODE[1]):+.1f} %)")
    print(f"  DDT lateral mode        {fl:.3f} Hz, damping ratio {zl:.4f}   Table 1 linear model: "
          f"{TABLE1_LATERAL_MODE[0]} Hz, {TABLE1_LATERAL_MODE[1]} ({pct(fl, TABLE1_LATERAL_MODE[0]):+.1f} %, "
          f"{pct(zl, TABLE1_LATERAL_MODE[1]):+.1f} %)")
    print(f"  DDT peak gain           {res['peak_gain_dB']:.2f} dB (yaw rate per steer angle, 1/s)")
    print(f"  RLT                     max |yaw rate| over the run = {res['rlt_max_yaw_rate']:.3g} rad/s: "
          f"null gain, as the paper says")
    print(f"  (fit of the co-simulated response: max relative residual {res['fit_residual']:.1e})")


def plot(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f = res["frequencies"]
    H = res["H"]["DDT"]
    fine = np.geomspace(f[0], f[-1], 2000)
    G = res["fit"](fine)
    fig, axes = plt.subplots(2, 2, figsize=(12, 7.5), constrained_layout=True)
    ax_g, ax_p = axes[0, 0], axes[1, 0]
    ax_g.semilogx(fine, 20 * np.log10(np.abs(G)), "C0-", lw=1.2, label="DDT: rational fit of the co-simulation")
    ax_g.semilogx(f, 20 * np.log10(np.abs(H)), "C0o", ms=4, label="DDT: co-simulated (multisine)")
    ax_p.semilogx(fine, np.degrees(np.unwrap(np.angle(G))), "C0-", lw=1.2)
    ax_p.semilogx(f, np.degrees(np.unwrap(np.angle(H))), "C0o", ms=4)
    for (fm, zm), label, ls in ((res["yaw_mode"], "yaw", ":"), (res["lateral_mode"], "lateral", "-.")):
        ax_g.axvline(fm, color="0.4", ls=ls, lw=1, label=f"fitted {label} mode: {fm:.2f} Hz, ζ = {zm:.3f}")
        ax_p.axvline(fm, color="0.4", ls=ls, lw=1)
    ax_g.axvline(PAPER_RESONANCE_HZ, color="C3", ls="--", lw=1, label="paper: measured resonance ≈ 0.8 Hz")
    # RLT's response is exactly zero: no point on a dB scale, so it has a legend entry only
    ax_g.plot([], [], "C1--", label="RLT: yaw rate ≡ 0 (null gain), off the dB scale")
    ax_g.set_ylabel("gain |r/δ| [dB re 1 1/s]")
    ax_g.set_title("Yaw rate / steer angle at 0 m/s")
    ax_g.legend(fontsize=8, loc="upper left")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_xlabel("frequency [Hz]")
    for ax in (ax_g, ax_p):
        ax.grid(True, which="both", alpha=0.3)

    ax_s, ax_r = axes[0, 1], axes[1, 1]
    exc = res["excitation"]
    for model, style in (("DDT", "C0-"), ("RLT", "C1--")):
        tr = res["trajectories"][model]
        last = tr.t >= tr.t[-1] - exc.period
        ax_r.plot(tr.t[last], np.degrees(tr.state("r")[last]), style, lw=1, label=model)
    tr = res["trajectories"]["DDT"]
    last = tr.t >= tr.t[-1] - exc.period
    ax_s.plot(tr.t[last], np.degrees(tr.ext("steer")[last]), "k-", lw=1, label="steer angle δ (multisine)")
    ax_s.set_ylabel("steer angle δ [deg]")
    ax_s.set_title("The last period of the run")
    ax_s.legend(fontsize=8, loc="upper right")
    ax_r.set_ylabel("yaw rate r [deg/s]")
    ax_r.set_xlabel("time [s]")
    ax_r.legend(fontsize=8, loc="upper right")
    for ax in (ax_s, ax_r):
        ax.grid(True, alpha=0.3)
    fig.suptitle("Koo & Tan snowblower steered at standstill: DDT tires give the yaw resonance, RLT tires nothing")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write(res: dict, path: Path) -> None:
    rows = []
    for model, H in res["H"].items():
        for fq, g in zip(res["frequencies"], H):
            mag = abs(g)
            rows.append([model, float(fq), float(mag), float(20 * math.log10(mag)) if mag > 0 else float("-inf"),
                         float(math.degrees(math.atan2(g.imag, g.real)))])
    write_csv(path, ["model", "frequency_Hz", "gain_per_s", "gain_dB", "phase_deg"], rows)


def main(argv=None) -> dict:
    return run_example(__doc__.split("\n\n")[0], NAME, simulate, report, write, plot, argv)


if __name__ == "__main__":
    main()
