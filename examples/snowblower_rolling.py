#!/usr/bin/env python3
"""Snowblower rolling slowly: yaw rate / steer angle with DDT, RLT and no tire lag.

Koo & Tan (2007, section 4.2 and Fig 5) compare three vehicle models of their 20.5 t
snowblower at walking pace (0.45 and 1.6 m/s):

* the improved bicycle model (Appendix A): DDT tires, and the body tied to the contact
  patches by the yaw spring-damper k1, c1;
* the bicycle model with RLT tires (Appendix D);
* the plain bicycle model without tire lag (Appendix C), Fy = Calpha alpha.

and report that with DDT the yaw resonance is about 10 dB lower than with RLT at
0.45 m/s, that DDT's phase starts to drop above 0.1 Hz (a steering lag no other model
has: the contact patch follows the steered wheel only after rolling sigmaPsi), and that
the steady-state yaw gain is r/delta = vr/(L + K vr^2) (eq 48).

This script co-simulates the three models (TireLag FMU instances for DDT and RLT, one per
axle; a Python tire without lag for the plain model), measures r/delta with a multisine
steer, and runs a step steer to the steady state. The vehicle and tire values are those
of snowblower_standstill.py (Table 1; see cosim/vehicle.py).

Eq 48 and K: the text extraction prints the understeer term as M vr/(l1 + l2) (l1/Calpha_f
- l2/Calpha_r). The steady state of the Appendix C model itself (and Kim 2008 eq 23, Wong)
gives K = M/L (l2/C_f - l1/C_r) with the axle cornering stiffnesses C = 2 Calpha, which
is what this script uses: K = 7.53e-3 rad/(m/s^2), an understeering vehicle. At these
speeds K vr^2 is under 0.6 % of L, so either sign changes the gain by less than 0.1 dB.

The improved model's steady state is not exactly eq 48: in a steady turn the front and
rear tires deflect differently, so the contact-patch line is turned against the body and
the spring k1 carries a moment. The script prints the difference (well below 0.1 %).

Writes out/snowblower_rolling.png (gain and phase of r/delta for each model at both
speeds, and the step-steer yaw rate per steer angle against eq 48) and
out/snowblower_rolling.csv (kind = frf or step, speed [m/s], model, frequency [Hz] or
time [s], gain [1/s], gain [dB], phase [deg]).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cosim import CoSimulation, Multisine, SNOWBLOWER_TIRE, load_fmu, log_harmonics, snowblower  # noqa: E402
from cosim.cli import print_table, run_example, write_csv  # noqa: E402
from cosim.frequency import measure_response  # noqa: E402

NAME = "snowblower_rolling"
SPEEDS = (0.45, 1.6)                       # m/s, Koo & Tan Fig 5(b, c)
MODELS = ("DDT", "RLT", "none")
LABELS = {"DDT": "DDT (improved bicycle model)", "RLT": "RLT (bicycle model with RLT)",
          "none": "no lag (plain bicycle model)"}
PAPER_RESONANCE_EXCESS_DB = 10.0           # RLT over DDT at 0.45 m/s (section 6, Fig 5(c))
PHASE_PROBES_HZ = (0.05, 0.1, 0.2, 0.3, 0.5)
STEER_AMPLITUDE = math.radians(1.0)
STEP_STEER = math.radians(1.0)
RESONANCE_BAND_HZ = (0.6, 1.6)   # the yaw resonance and the lateral mode


def settings(quick: bool) -> dict:
    if quick:
        return {"h": 0.01, "base": 0.02, "count": 30, "settle": 30.0, "h_step": 0.02, "t_step": 60.0}
    return {"h": 0.01, "base": 0.01, "count": 45, "settle": 60.0, "h_step": 0.02, "t_step": 90.0}


def excitation(s: dict) -> Multisine:
    """Log-spaced over 0.02-3 Hz, plus every harmonic in the band of the yaw and lateral
    modes, to resolve the lightly damped RLT response (its peak, and the notch at its
    lateral mode)."""
    base = s["base"]
    wide = set(log_harmonics(0.02, 3.0, base, s["count"]))
    lo, hi = RESONANCE_BAND_HZ
    band = set(range(math.ceil(lo / base - 1e-9), math.floor(hi / base + 1e-9) + 1))
    return Multisine(base, tuple(sorted(wide | band)), STEER_AMPLITUDE)


def peak(f: np.ndarray, H: np.ndarray) -> tuple[float, float]:
    """(frequency, gain in dB) of the maximum of |H|, refined by a parabola through the
    three points around the largest sample (in dB over frequency)."""
    g = 20 * np.log10(np.abs(H))
    i = int(np.argmax(g))
    if 0 < i < len(f) - 1:
        c = np.polyfit(f[i - 1:i + 2] - f[i], g[i - 1:i + 2], 2)
        if c[0] < 0:
            x = -c[1] / (2 * c[0])
            if abs(x) <= max(f[i + 1] - f[i], f[i] - f[i - 1]):
                return float(f[i] + x), float(np.polyval(c, x))
    return float(f[i]), float(g[i])


def step_steer(vehicle, h: float, duration: float):
    """Steer ramped to STEP_STEER over 1 s, then held: (t, r/delta_0)."""
    N = int(round(duration / h))
    t = np.arange(N + 1) * h
    W = np.zeros((N + 1, len(vehicle.external_names)))
    W[:, vehicle.external_names.index("steer")] = STEP_STEER * np.clip(t / 1.0, 0.0, 1.0)
    traj = CoSimulation(vehicle, h).run(W)
    return t, traj.state("r") / STEP_STEER


def simulate(fmu_path, quick: bool = False) -> dict:
    fmu = load_fmu(fmu_path)
    s = settings(quick)
    exc = excitation(s)
    f = exc.frequencies
    res = {"excitation": exc, "h": s["h"], "frequencies": f, "H": {}, "step": {}, "peaks": {},
           "steady_gain": {}, "eq48": {}, "phase_lag_deg": {}}
    for speed in SPEEDS:
        for model in MODELS:
            with snowblower(fmu, model, speed) as vehicle:
                H, _ = measure_response(vehicle, s["h"], exc, s["settle"])
            with snowblower(fmu, model, speed) as vehicle:
                t, r_per_delta = step_steer(vehicle, s["h_step"], s["t_step"])
                K = vehicle.understeer_gradient(SNOWBLOWER_TIRE["Calpha"], SNOWBLOWER_TIRE["Calpha"])
                L = vehicle.p.wheelbase
            res["H"][speed, model] = H
            res["step"][speed, model] = (t, r_per_delta)
            res["peaks"][speed, model] = peak(f, H)
            res["steady_gain"][speed, model] = float(r_per_delta[-1])
        res["eq48"][speed] = speed / (L + K * speed ** 2)
        res["K"] = K
        # DDT's extra phase lag relative to the plain bicycle model (the steering lag)
        lag = np.degrees(np.unwrap(np.angle(res["H"][speed, "DDT"]))
                         - np.unwrap(np.angle(res["H"][speed, "none"])))
        res["phase_lag_deg"][speed] = {fp: float(np.interp(fp, f, lag)) for fp in PHASE_PROBES_HZ}
        dB = lambda m: 20 * np.log10(np.abs(res["H"][speed, m]))  # noqa: E731
        res.setdefault("max_gain_difference_dB", {})[speed] = float(np.max(np.abs(dB("DDT") - dB("none"))))
        res.setdefault("max_phase_difference_deg", {})[speed] = float(np.max(np.abs(lag)))
    res["resonance_excess_dB"] = {v: res["peaks"][v, "RLT"][1] - res["peaks"][v, "DDT"][1] for v in SPEEDS}
    return res


def report(res: dict) -> None:
    print("Snowblower rolling (Koo & Tan 2007, Fig 5): yaw rate / steer angle")
    rows = []
    for (speed, model), (fp, gp) in res["peaks"].items():
        if model == "none":   # no resonance: its gain only falls with frequency
            fp = gp = "-"
        rows.append([f"{speed:g}", LABELS[model], fp, gp, res["steady_gain"][speed, model],
                     res["eq48"][speed], 100 * (res["steady_gain"][speed, model] / res["eq48"][speed] - 1)])
    print_table("  resonance peak and steady-state gain r/delta (step steer) against eq 48, vr/(L + K vr^2):",
                ["vr [m/s]", "model", "peak [Hz]", "peak [dB]", "steady [1/s]", "eq 48 [1/s]", "diff [%]"],
                rows, {2: "{:.3f}", 3: "{:.2f}", 4: "{:.5f}", 5: "{:.5f}", 6: "{:+.3f}"})
    print(f"  K = {res['K']:.4g} rad/(m/s^2) (understeer gradient from Appendix C)")
    for speed in SPEEDS:
        paper = f" (paper: about {PAPER_RESONANCE_EXCESS_DB:g} dB)" if speed == 0.45 else ""
        print(f"  {speed:g} m/s: RLT resonance {res['resonance_excess_dB'][speed]:.1f} dB above DDT{paper}")
    for speed in SPEEDS:
        lags = ", ".join(f"{fp:g} Hz {lag:+.1f}" for fp, lag in res["phase_lag_deg"][speed].items())
        print(f"  {speed:g} m/s: DDT phase minus no-lag phase [deg]: {lags}")
    for speed in SPEEDS:
        print(f"  {speed:g} m/s: largest DDT vs no-lag difference over 0.02-3 Hz: "
              f"{res['max_gain_difference_dB'][speed]:.1f} dB, {res['max_phase_difference_deg'][speed]:.0f} deg "
              f"(paper, Fig 5(b): up to 10 dB and 200 deg, against a plain model fitted to the data "
              f"separately, so only indicative)")


def plot(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f = res["frequencies"]
    colors = {"DDT": "C0", "RLT": "C1", "none": "C2"}
    fig, axes = plt.subplots(3, len(SPEEDS), figsize=(13, 10), constrained_layout=True)
    for j, speed in enumerate(SPEEDS):
        ax_g, ax_p, ax_s = axes[0, j], axes[1, j], axes[2, j]
        for model in MODELS:
            H = res["H"][speed, model]
            c = colors[model]
            ax_g.semilogx(f, 20 * np.log10(np.abs(H)), "-", color=c, lw=1.2, marker=".", ms=3,
                          label=LABELS[model])
            ax_p.semilogx(f, np.degrees(np.unwrap(np.angle(H))), "-", color=c, lw=1.2, marker=".", ms=3)
            t, g = res["step"][speed, model]
            ax_s.plot(t, g, "-", color=c, lw=1.2, label=LABELS[model])
        eq48 = res["eq48"][speed]
        ax_g.axhline(20 * np.log10(eq48), color="k", ls=":", lw=1, label="steady state, eq 48")
        ax_s.axhline(eq48, color="k", ls=":", lw=1, label=f"eq 48: vr/(L + K vr²) = {eq48:.4f} 1/s")
        ax_p.axvline(0.1, color="0.5", ls="--", lw=0.8)
        ax_p.text(0.105, 0.05, "0.1 Hz", transform=ax_p.get_xaxis_transform(), fontsize=8, color="0.4")
        excess = res["resonance_excess_dB"][speed]
        ax_g.set_title(f"{speed:g} m/s: RLT peak {excess:.1f} dB above DDT")
        ax_g.set_ylabel("gain |r/δ| [dB re 1 1/s]")
        ax_p.set_ylabel("phase [deg]")
        ax_p.set_xlabel("frequency [Hz]")
        ax_s.set_ylabel("yaw rate / steer angle [1/s]")
        ax_s.set_xlabel("time [s] (steer ramped to 1° over 1 s, then held)")
        ax_s.set_xlim(0.0, 20.0)   # the run goes on to the steady state; the transient is over by 20 s
        ax_s.set_title(f"{speed:g} m/s: step steer")
        ax_g.legend(fontsize=8, loc="lower left")
        ax_s.legend(fontsize=8, loc="lower right")
        for ax in (ax_g, ax_p, ax_s):
            ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("Koo & Tan snowblower rolling slowly: DDT damps the yaw resonance and lags the steering; "
                 "all three share the steady state")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write(res: dict, path: Path) -> None:
    rows = []
    for (speed, model), H in res["H"].items():
        for fq, g in zip(res["frequencies"], H):
            rows.append(["frf", speed, model, float(fq), float(abs(g)), float(20 * math.log10(abs(g))),
                         float(math.degrees(math.atan2(g.imag, g.real)))])
    for (speed, model), (t, g) in res["step"].items():
        for tk, gk in zip(t, g):
            rows.append(["step", speed, model, float(tk), float(gk), "", ""])
    write_csv(path, ["kind", "speed_m_per_s", "model", "frequency_Hz_or_time_s", "gain_per_s", "gain_dB",
                     "phase_deg"], rows)


def main(argv=None) -> dict:
    return run_example(__doc__.split("\n\n")[0], NAME, simulate, report, write, plot, argv)


if __name__ == "__main__":
    main()
