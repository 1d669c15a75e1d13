#!/usr/bin/env python3
"""Bode plots of the four tire models: the co-simulated FMU against docs/specification.md 5.

One TireLag instance per model and speed (0, 1.6 and 20 m/s) is driven with a multisine
lateral velocity vy and, at the same time, a multisine slip velocity vsx (they reach
different outputs: vy only Fy, vsx only Fx). The inputs are given at every communication
point with their rates (fmi2SetRealInputDerivatives), so the FMU steps the piecewise
linear input exactly, and the frequency response is read from the last period.

The analytic transfer functions of docs/specification.md 5, written as Fy = -Z vy, Fx = -Zx vsx:

    RLT          Z = C_y/(s + rho/sigmaY)
    DDT          Z = (dampingY s + C_y)/(s + rho/sigmaY)
    SecondOrder  Z = Zc Zm/(Zc + Zm), Zc = k_y/s + carcassDampingY, Zm = contactMass s + kT_y/(s + rho/sigmaTread)
    RingBody     Z as SecondOrder with ringMass, ringDampingY
    longitudinal the same forms with C_x, sigmaX, dampingX; RingBody:
                 Fx = -(kT_x/(s + rho/sigmaTread)) Zc/(Zc + Zm) vsx, Zc = k_x/s + ringDampingX,
                 Zm = (ringInertia/Re^2) s + kT_x/(s + rho/sigmaTread)

with C_y = Calpha/sigmaY, k_y = Calpha/(sigmaY - sigmaTread), kT_y = Calpha/sigmaTread
(and x alike with Ckappa, sigmaX). The parameters are the FMU's defaults, read from its
model description. At speed the plots show the force per slip, Fy/alpha = rho Z and
Fx/kappa = rho Zx (alpha = -vy/rho, kappa = -vsx/rho); at 0 m/s, where there is no slip,
the impedances Z and Zx themselves.

Exactness: the measured response is that of the piecewise linear input, whose
interpolation adds components at f + m/h that sampling folds back onto f
(cosim.frequency.sampled_response). Compared with that, the FMU agrees to rounding
(1e-12). The plain continuous transfer function differs from it by the interpolation,
about 2 (f h)^2 |Z(far)/Z(f)|: 1e-6 for RLT, whose force falls off at high frequency, and
up to 2e-3 at 20 Hz with 1 ms steps for the models with a damper, which pass high
frequencies straight through. Both numbers are printed.

The FMI 3.0 FMU (--fmu target/fmu/fmi3/TireLag.fmu) has no input derivatives: each step
holds the mean of its two samples (cosim.tire), and the response is compared with that
input's sampled response (sampled_response(..., hold="mean")), again to rounding; against
the continuous transfer function the hold adds up to about 1e-2 at 20 Hz.

Writes out/bode_models.png (lateral), out/bode_models_longitudinal.png and
out/bode_models.csv (model, speed [m/s], direction, frequency [Hz], co-simulated and
analytic Z as real and imaginary parts [N.s/m], relative error to the sampled analytic
response).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cosim import TIRE_MODELS, Multisine, TireLag, frequency_response, load_fmu, log_harmonics  # noqa: E402
from cosim.cli import output_paths, parser, print_table, write_csv  # noqa: E402
from cosim.fmi import FMI2  # noqa: E402
from cosim.frequency import sampled_response, steps_per_period  # noqa: E402

NAME = "bode_models"
MODELS = tuple(TIRE_MODELS)
SPEEDS = (0.0, 1.6, 20.0)
AMPLITUDE = 0.05          # m/s, peak of the vy and vsx multisines
DIRECTIONS = {"lateral": ("vy", "Fy"), "longitudinal": ("vsx", "Fx")}


def settings(quick: bool) -> dict:
    if quick:
        return {"h": 0.001, "base": 0.1, "count": 20, "settle": 10.0}
    return {"h": 0.001, "base": 0.05, "count": 40, "settle": 10.0}


def impedance(model: str, p: dict, rho: float, direction: str):
    """Z(f) (f in Hz, any array) with F = -Z v, from docs/specification.md 5; p: FMU parameters."""
    if direction == "lateral":
        C, sigma, damping = p["Calpha"], p["sigmaY"], p["dampingY"]
    else:
        C, sigma, damping = p["Ckappa"], p["sigmaX"], p["dampingX"]
    lag = rho / sigma
    tread = rho / p["sigmaTread"]
    k = C / (sigma - p["sigmaTread"])     # carcass
    kT = C / p["sigmaTread"]              # tread

    def Z(f):
        s = 2j * math.pi * np.asarray(f, dtype=float)
        if model == "RLT" or (model == "SecondOrder" and direction == "longitudinal"):
            return (C / sigma) / (s + lag)
        if model == "DDT":
            return (damping * s + C / sigma) / (s + lag)
        if direction == "lateral":
            mass, d = ((p["contactMass"], p["carcassDampingY"]) if model == "SecondOrder"
                       else (p["ringMass"], p["ringDampingY"]))
            Zc = k / s + d
            Zm = mass * s + kT / (s + tread)
            return Zc * Zm / (Zc + Zm)
        # RingBody, circumferential: the force comes through the tread
        Zc = k / s + p["ringDampingX"]
        Zm = p["ringInertia"] / p["Re"] ** 2 * s + kT / (s + tread)
        return (kT / (s + tread)) * Zc / (Zc + Zm)

    return Z


def drive(tire: TireLag, u: np.ndarray, h: float) -> np.ndarray:
    """Step the tire through the samples u (N+1 x inputs), linear in between; return the
    outputs at every sample (N+1 x outputs)."""
    Y = np.empty((len(u), len(tire.output_names)))
    Y[0] = tire.begin_step(u[0])
    for k in range(len(u) - 1):
        tire.begin_step(u[k])
        Y[k + 1] = tire.advance(h, u[k], u[k + 1])
    return Y


def simulate(fmu_path, quick: bool = False) -> dict:
    fmu = load_fmu(fmu_path)
    s = settings(quick)
    h = s["h"]
    exc = Multisine(s["base"], log_harmonics(s["base"], 20.0, s["base"], s["count"]), AMPLITUDE)
    P = steps_per_period(exc, h)
    N = math.ceil(s["settle"] / exc.period) * P + P
    t = np.arange(N + 1) * h
    signal = exc(t)
    u = np.column_stack([signal, signal])          # vy and vsx
    f = exc.frequencies
    params = fmu.parameters()
    hold = "ramp" if fmu.fmi_version == FMI2 else "mean"     # what the tire does between samples
    measured, analytic, sampled = {}, {}, {}
    for model in MODELS:
        for speed in SPEEDS:
            with TireLag(fmu, model, name=f"{model}-{speed}", inputs=("vy", "vsx"), outputs=("Fy", "Fx"),
                         friction="Unlimited") as tire:   # docs/specification.md 5 is the linear model
                tire.set_inputs(vx=speed)
                Y = drive(tire, u, h)
            for i, (direction, (inp, out)) in enumerate(DIRECTIONS.items()):
                Z = impedance(model, params, abs(speed), direction)
                measured[model, speed, direction] = -frequency_response(u[:, i], Y[:, i], exc, h)
                analytic[model, speed, direction] = Z(f)
                sampled[model, speed, direction] = sampled_response(Z, f, h, hold=hold)
    err_sampled = {k: float(np.max(np.abs(measured[k] / sampled[k] - 1.0))) for k in measured}
    err_analytic = {k: float(np.max(np.abs(measured[k] / analytic[k] - 1.0))) for k in measured}
    return {"frequencies": f, "h": h, "hold": hold, "measured": measured, "analytic": analytic, "sampled": sampled,
            "error_sampled": err_sampled, "error_analytic": err_analytic, "parameters": params}


def report(res: dict) -> None:
    rows = []
    for (model, speed, direction), e in res["error_sampled"].items():
        rows.append([model, f"{speed:g}", direction, e, res["error_analytic"][model, speed, direction]])
    print_table("Four tire models, co-simulated frequency response against docs/specification.md 5 "
                "(max relative difference over 0.05-20 Hz):",
                ["model", "vx [m/s]", "direction", "vs sampled analytic", "vs continuous analytic"], rows,
                {3: "{:.1e}", 4: "{:.1e}"})
    applied = {"ramp": "piecewise linear input", "mean": "input held at each step's mean (FMI 3.0)"}
    print(f"  worst: {max(res['error_sampled'].values()):.1e} against the analytic response to the "
          f"{applied[res['hold']]}, {max(res['error_analytic'].values()):.1e} against the continuous "
          f"transfer function (the difference is the input between the {1e3 * res['h']:g} ms samples)")


def plot(res: dict, direction: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f = res["frequencies"]
    fine = np.geomspace(f[0], f[-1], 600)
    params = res["parameters"]
    force, slip = ("Fy", "α") if direction == "lateral" else ("Fx", "κ")
    vel = "vy" if direction == "lateral" else "vsx"
    slip_unit = "N/rad" if direction == "lateral" else "N"
    colors = {1.6: "C0", 20.0: "C3", 0.0: "C2"}
    fig, axes = plt.subplots(4, len(MODELS), figsize=(16, 12), constrained_layout=True, sharex=True)
    for j, model in enumerate(MODELS):
        ax_g, ax_p, ax_zg, ax_zp = axes[:, j]
        for speed in SPEEDS:
            Z = impedance(model, params, speed, direction)
            scale = speed if speed > 0 else 1.0          # F/slip = rho Z at speed, Z at standstill
            G = scale * Z(fine)
            M = scale * res["measured"][model, speed, direction]
            gain_ax, phase_ax = (ax_g, ax_p) if speed > 0 else (ax_zg, ax_zp)
            c = colors[speed]
            gain_ax.loglog(fine, np.abs(G), "-", color=c, lw=1.2, label=f"{speed:g} m/s: docs/specification.md 5")
            gain_ax.loglog(f, np.abs(M), "o", color=c, ms=3.5, mfc="none", label=f"{speed:g} m/s: FMU")
            phase_ax.semilogx(fine, np.degrees(np.angle(G)), "-", color=c, lw=1.2)
            phase_ax.semilogx(f, np.degrees(np.angle(M)), "o", color=c, ms=3.5, mfc="none")
        ax_g.set_title(model)
        for ax in axes[:, j]:
            ax.grid(True, which="both", alpha=0.3)
        for ax in (ax_p, ax_zp):   # a fixed range: RLT's -90 deg at 0 m/s is flat, not noise
            ax.set_ylim(-95.0, 5.0)
            ax.set_yticks(np.arange(-90.0, 1.0, 15.0))
        ax_g.legend(fontsize=7, loc="lower left")
        ax_zg.legend(fontsize=7, loc="lower left")
        ax_zp.set_xlabel("frequency [Hz]")
    axes[0, 0].set_ylabel(f"|{force}/{slip}| = ρ|Z| [{slip_unit}]")
    axes[1, 0].set_ylabel(f"phase of {force}/{slip} [deg]")
    axes[2, 0].set_ylabel(f"|Z| = |{force}/{vel}| at 0 m/s [N·s/m]")
    axes[3, 0].set_ylabel("phase of Z at 0 m/s [deg]")
    fig.suptitle(f"{direction.capitalize()} response of the four TireLag models: FMU co-simulation (circles) "
                 f"against the transfer functions of docs/specification.md 5 (lines); {force} = -Z·{vel}")
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write(res: dict, path: Path) -> None:
    rows = []
    for (model, speed, direction), M in res["measured"].items():
        A = res["analytic"][model, speed, direction]
        S = res["sampled"][model, speed, direction]
        for fq, m, a, s in zip(res["frequencies"], M, A, S):
            rows.append([model, speed, direction, float(fq), float(m.real), float(m.imag), float(a.real),
                         float(a.imag), float(abs(m / s - 1.0))])
    write_csv(path, ["model", "speed_m_per_s", "direction", "frequency_Hz", "Z_cosim_re", "Z_cosim_im",
                     "Z_analytic_re", "Z_analytic_im", "relative_error_to_sampled_analytic"], rows)


def main(argv=None) -> dict:
    args = parser(__doc__.split("\n\n")[0]).parse_args(argv)
    res = simulate(args.fmu, args.quick)
    png, csv_path = output_paths(args.out_dir, NAME)
    png_long = png.with_name(f"{NAME}_longitudinal.png")
    report(res)
    write(res, csv_path)
    plot(res, "lateral", png)
    plot(res, "longitudinal", png_long)
    print(f"wrote {png}\nwrote {png_long}\nwrote {csv_path}")
    return res


if __name__ == "__main__":
    main()
