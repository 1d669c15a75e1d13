#!/usr/bin/env python3
"""The friction limit (docs/specification.md 4c): steady-state Fy(alpha) and the standstill loop.

TireLag bounds the force of every contact element with a rate-independent friction slider,
chosen with the Integer parameter `friction`:

  Unlimited  no slider: the linear tire of docs/specification.md 4, Fy = Calpha(Fz) alpha
  Coulomb    one slider per element: exactly linear up to Fmax = muY(Fz) Fz, flat beyond,
             Fy = sign(alpha) min(Calpha(Fz) |alpha|, Fmax)
  Brush      (the default) four parallel spring-slider branches per element, fitted to the
             brush curve Fmax (3t - 3t^2 + t^3), t = min(1, Calpha(Fz) |alpha| / (3 Fmax)),
             within 0.013 Fmax, and exactly linear below 0.2 Fmax

with the load laws of docs/specification.md 4b/4c (x = Fz/Fz0, c2 = calphaLoadPeak):
Calpha(Fz) = Calpha x (1 + 1/c2^2)/(1 + x^2/c2^2) and muY(Fz) = muY (1 + muLoadSensitivity (x - 1)).

Figure 1, steady state. The default DDT tire rolls at vx = 10 m/s with the slip angle
alpha held: vy = -vx tan(alpha), so the FMU's slip -vy/|vx| is tan(alpha) (the brush model's
lateral slip). Each point is its own run of 0.5 s steps (the lag sigmaY(Fz)/vx is at most
0.1 s, and the FMU steps exactly, so a long step is as good as many short ones), at least
four, until the last step changes Fy by less than 1e-12 Fmax. At Fz0 for the three
laws with the analytic brush curve, at 0.5, 1 and 1.5 Fz0 for Coulomb and Brush (the load
dependence of Calpha and mu), and the Brush fit's deviation from the brush curve.

Figure 2, standstill. An RLT tire (undamped, so the loop's corners are sharp) at vx = 0:
the wheel is pushed sideways at constant vy = 0.1 m/s to y = +2.5 Fmax/C_y, reversed to
-2.5 Fmax/C_y and pushed back to +2.5 Fmax/C_y (C_y = Calpha/sigmaY). Fy against the
wheel's lateral displacement y (the integral of vy): Unlimited is the elastic line
Fy = -C_y y; Coulomb is elastic-perfectly-plastic (slope C_y, plateaus at +-Fmax, and after
a reversal the force needs exactly 2 Fmax/C_y of travel to swing to the other limit: no
wind-up); Brush rounds the corners (its branches slide one after the other; the last,
at the largest breakpoint x_4 = 2.3201, so its swing takes 2 x_4 Fmax/C_y). vy is held over
each step (exact for the FMU), and the steps land on the corners of the Coulomb loop.
The reversal travel is measured on the elastic line through the last two samples before
the force reaches the opposite limit.

Printed: the Coulomb plateau against mu(Fz) Fz, the Brush fit's largest deviation from the
brush curve, the linearity below 0.2 Fmax, and the loop's reversal travel against
2 Fmax/C_y.

Writes out/friction_laws.png, out/friction_laws.csv (law, load, slip angle, vy, Fy and the
analytic curves), out/friction_standstill_loop.png and out/friction_standstill_loop.csv
(law, time, vy, y, Fy, deflY); with --docs it also copies the two PNGs to docs/ (the
README's figures).
"""

from __future__ import annotations

import math
import shutil
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cosim import TireLag, load_fmu  # noqa: E402
from cosim.cli import PROJECT, output_paths, parser, print_table, write_csv  # noqa: E402

NAME = "friction_laws"
LOOP_NAME = "friction_standstill_loop"
DOCS = PROJECT / "docs"

LAWS = ("Unlimited", "Coulomb", "Brush")
VX = 10.0                        # m/s, steady-state rolling speed
ALPHA_MAX_DEG = 20.0
LOAD_RATIOS = (0.5, 1.0, 1.5)    # Fz/Fz0
SETTLE_STEP = 0.5                # s, one steady-state step (>= 5 lags sigmaY(Fz)/vx)
SETTLE_TOL = 1e-12               # of Fmax: the last step changed Fy by less than this
MAX_SETTLE_STEPS = 40
# The Brush branches' breakpoints x_i = phi_i/w_i (src/physics/brush.rs BRUSH_BRANCHES),
# x = Calpha(Fz) |alpha| / Fmax: the fit's deviation from the brush curve peaks at these
# (0.0130 Fmax at x = 0.2), so the sweep includes them, and Coulomb's kink x = 1 and the
# brush curve's full slide x = 3.
BRUSH_BREAKPOINTS = (0.2, 0.78680, 1.45421, 2.3201491236799816)
SPECIAL_X = BRUSH_BREAKPOINTS + (1.0, 3.0)

LOOP_MODEL = "RLT"
LOOP_VY = 0.1                    # m/s, push speed
LOOP_AMPLITUDE = 2.5             # displacement amplitude in units of Fmax/C_y
COLORS = {"Unlimited": "0.55", "Coulomb": "tab:blue", "Brush": "tab:red"}
LOAD_COLORS = {0.5: "tab:green", 1.0: "tab:red", 1.5: "tab:purple"}


# --------------------------------------------------------------------------- the laws (docs/specification.md 4b, 4c)

def load_laws(p: dict, ratio: float) -> dict:
    """Calpha(Fz), muY(Fz), Fmax = muY(Fz) Fz and C_y at Fz = ratio Fz0."""
    c2 = p["calphaLoadPeak"]
    calpha = p["Calpha"] * ratio * (1.0 + 1.0 / c2 ** 2) / (1.0 + ratio ** 2 / c2 ** 2)
    mu = p["muY"] * max(0.0, 1.0 + p["muLoadSensitivity"] * (ratio - 1.0))
    Fz = ratio * p["Fz0"]
    return {"Fz": Fz, "Calpha": calpha, "mu": mu, "Fmax": mu * Fz, "C_y": p["Calpha"] / p["sigmaY"]}


def brush_curve(x):
    """The brush model's force / Fmax, 3t - 3t^2 + t^3 with t = min(1, |x|/3), x = Calpha |slip| / Fmax."""
    t = np.minimum(1.0, np.abs(np.asarray(x, float)) / 3.0)
    return np.sign(x) * (3.0 * t - 3.0 * t ** 2 + t ** 3)


# --------------------------------------------------------------------------- 1. steady state

def slip_angles(quick: bool, law_of_load: dict) -> np.ndarray:
    """The sweep in rad: a grid from 0 to ALPHA_MAX_DEG, plus the angles where the laws
    have their kinks (SPECIAL_X) at this load."""
    step = 1.0 if quick else 0.25
    grid = np.radians(np.arange(0.0, ALPHA_MAX_DEG + step / 2, step))
    special = [math.atan(x * law_of_load["Fmax"] / law_of_load["Calpha"]) for x in SPECIAL_X]
    special = [a for a in special if a <= math.radians(ALPHA_MAX_DEG)]
    return np.unique(np.concatenate([grid, special]))


def steady_force(fmu, law: str, Fz: float, alpha: float, Fmax: float) -> tuple[float, float, int]:
    """Fy at steady state of the default tire model (DDT) rolling at VX with vy = -VX tan(alpha)
    held; returns (Fy, |change of Fy over the last step|, steps)."""
    u = np.array([-VX * math.tan(alpha)])
    with TireLag(fmu, "DDT", name=f"{law}-{Fz:g}-{alpha:.6f}", inputs=("vy",), outputs=("Fy",),
                 friction=law) as tire:
        tire.set_inputs(vx=VX, Fz=Fz)
        previous = tire.begin_step(u)[0]
        for k in range(1, MAX_SETTLE_STEPS + 1):
            Fy = tire.advance(SETTLE_STEP, u, u)[0]
            change = abs(Fy - previous)
            if k >= 4 and change <= SETTLE_TOL * Fmax:
                break
            previous = Fy
    return float(Fy), float(change), k


def steady_state(fmu, quick: bool) -> list[dict]:
    p = fmu.parameters()
    rows = []
    for ratio in LOAD_RATIOS:
        laws_here = LAWS if ratio == 1.0 else ("Coulomb", "Brush")
        L = load_laws(p, ratio)
        for law in laws_here:
            for alpha in slip_angles(quick, L):
                Fy, change, steps = steady_force(fmu, law, L["Fz"], alpha, L["Fmax"])
                slip = math.tan(alpha)
                x = L["Calpha"] * slip / L["Fmax"]
                rows.append({"law": law, "load_ratio": ratio, "Fz": L["Fz"], "alpha": alpha, "slip": slip,
                             "vy": -VX * slip, "Fy": Fy, "change": change, "steps": steps,
                             "Calpha": L["Calpha"], "mu": L["mu"], "Fmax": L["Fmax"], "x": x,
                             "linear": L["Calpha"] * slip,
                             "coulomb": math.copysign(min(abs(L["Calpha"] * slip), L["Fmax"]), slip),
                             "brush": L["Fmax"] * float(brush_curve(x))})
    return rows


def steady_numbers(rows: list[dict]) -> dict:
    """Coulomb plateau, Brush deviation and linearity, convergence; per load ratio."""
    out = {"convergence": max(r["change"] / r["Fmax"] for r in rows), "loads": {}}
    for ratio in LOAD_RATIOS:
        here = [r for r in rows if r["load_ratio"] == ratio]
        L = here[0]
        coulomb = [r for r in here if r["law"] == "Coulomb"]
        brush = [r for r in here if r["law"] == "Brush"]
        saturated = [r for r in coulomb if r["x"] >= 1.0 + 1e-9]
        coulomb_linear = [r for r in coulomb if r["x"] <= 1.0 - 1e-9 and r["x"] > 0]
        brush_linear = [r for r in brush if 0 < r["x"] <= 0.2 + 1e-12]
        dev = [abs(r["Fy"] - r["brush"]) / r["Fmax"] for r in brush]
        worst = brush[int(np.argmax(dev))]
        out["loads"][ratio] = {
            "Fz": L["Fz"], "Calpha": L["Calpha"], "mu": L["mu"], "Fmax": L["Fmax"],
            "coulomb_plateau": float(np.mean([r["Fy"] for r in saturated])),
            "coulomb_plateau_error": max(abs(r["Fy"] / r["Fmax"] - 1.0) for r in saturated),
            "coulomb_linear_error": max(abs(r["Fy"] / r["linear"] - 1.0) for r in coulomb_linear),
            "brush_max_deviation": max(dev),
            "brush_max_deviation_x": worst["x"],
            "brush_max_deviation_alpha_deg": math.degrees(worst["alpha"]),
            "brush_linear_error": max(abs(r["Fy"] / r["linear"] - 1.0) for r in brush_linear),
            "brush_linear_up_to": max(r["Fy"] for r in brush_linear) / L["Fmax"],
            "brush_plateau_error": max(abs(r["Fy"] / r["Fmax"] - 1.0) for r in brush
                                       if r["x"] >= BRUSH_BREAKPOINTS[-1] + 1e-9),
        }
        if ratio == 1.0:
            unl = [r for r in here if r["law"] == "Unlimited" and r["x"] > 0]
            out["unlimited_linear_error"] = max(abs(r["Fy"] / r["linear"] - 1.0) for r in unl)
    return out


# --------------------------------------------------------------------------- 2. standstill loop

def loop_schedule(d: float, quick: bool):
    """Segments (vy, steps) of the push-reverse-push cycle and the step h: the wheel goes
    0 -> +A -> -A -> +A, A = LOOP_AMPLITUDE d, d = Fmax/C_y, with n steps per d of travel."""
    n = 40 if quick else 200
    h = d / LOOP_VY / n
    A = LOOP_AMPLITUDE
    segments = [(+LOOP_VY, round(A * n)), (-LOOP_VY, round(2 * A * n)), (+LOOP_VY, round(2 * A * n))]
    return segments, h, n


def standstill_loop(fmu, quick: bool) -> dict:
    p = fmu.parameters()
    L = load_laws(p, 1.0)
    d = L["Fmax"] / L["C_y"]
    segments, h, n = loop_schedule(d, quick)
    runs = {}
    for law in LAWS:
        with TireLag(fmu, LOOP_MODEL, name=f"loop-{law}", inputs=("vy",), outputs=("Fy", "deflY"),
                     friction=law) as tire:
            tire.set_inputs(vx=0.0)
            t, y, vys = [0.0], [0.0], [0.0]
            out = [tire.begin_step(np.array([0.0]))]
            k = 0
            for vy, steps in segments:
                u = np.array([vy])
                out[-1] = tire.begin_step(u)      # vy jumps here (RLT's Fy does not feed through vy)
                vys[-1] = vy
                for _ in range(steps):
                    out.append(tire.advance(h, u, u))
                    k += 1
                    t.append(k * h)
                    y.append(y[-1] + vy * h)
                    vys.append(vy)
        out = np.array(out)
        runs[law] = {"t": np.array(t), "y": np.array(y), "vy": np.array(vys), "Fy": out[:, 0], "deflY": out[:, 1]}
    return {"runs": runs, "d": d, "h": h, "n": n, "segments": segments, **L}


def reversal_travel(run: dict, Fmax: float) -> list[dict]:
    """For each reversal of vy: the travel from the reversal point until Fy reaches the
    opposite limit, on the straight line through the last two samples before it reaches it
    (exact for an elastic segment, whatever the sample spacing)."""
    y, Fy, vy = run["y"], run["Fy"], run["vy"]
    result = []
    for i in np.flatnonzero(np.sign(vy[1:]) != np.sign(vy[:-1])) + 1:
        # from sample i on the wheel moves with sign(vy[i]); the force heads for -sign(vy) Fmax
        target = -np.sign(vy[i]) * Fmax
        reached = np.flatnonzero(target * Fy[i:] >= Fmax * Fmax * (1.0 - 1e-9))
        if len(reached) == 0:
            continue
        j = i + reached[0]
        a, b = j - 2, j - 1
        if a < i:
            continue
        slope = (Fy[b] - Fy[a]) / (y[b] - y[a])
        y_hit = y[b] + (target - Fy[b]) / slope
        result.append({"y_reversal": float(y[i]), "F_reversal": float(Fy[i]), "y_limit": float(y_hit),
                       "travel": float(abs(y_hit - y[i])), "slope": float(slope)})
    return result


def loop_numbers(loop: dict) -> dict:
    Fmax, d = loop["Fmax"], loop["d"]
    out = {"Fmax": Fmax, "C_y": loop["C_y"], "d": d, "exact_travel": 2.0 * d}
    for law in ("Coulomb", "Brush"):
        run = loop["runs"][law]
        rev = reversal_travel(run, Fmax)
        on_limit = np.abs(run["Fy"]) > Fmax * (1 - 1e-6)
        out[law] = {"reversals": rev,
                    "travel": [r["travel"] for r in rev],
                    "plateau_error": float(np.max(np.abs(np.abs(run["Fy"][on_limit]) / Fmax - 1.0))),
                    "max_abs_Fy": float(np.max(np.abs(run["Fy"])))}
    # the first (virgin) push: Coulomb reaches -Fmax after d of travel
    run = loop["runs"]["Coulomb"]
    first = np.flatnonzero(run["Fy"] <= -Fmax * (1 - 1e-9))[0]
    out["Coulomb"]["first_push_travel"] = float(run["y"][first])
    unl = loop["runs"]["Unlimited"]
    moving = np.abs(unl["y"]) > 0
    out["Unlimited_stiffness_error"] = float(np.max(np.abs(-unl["Fy"][moving] / unl["y"][moving] / loop["C_y"] - 1.0)))
    out["Brush_exact_travel"] = 2.0 * BRUSH_BREAKPOINTS[-1] * d
    return out


# --------------------------------------------------------------------------- driver

def simulate(fmu_path, quick: bool = False) -> dict:
    fmu = load_fmu(fmu_path)
    rows = steady_state(fmu, quick)
    loop = standstill_loop(fmu, quick)
    return {"rows": rows, "steady": steady_numbers(rows), "loop": loop, "loop_numbers": loop_numbers(loop),
            "parameters": fmu.parameters()}


def report(res: dict) -> None:
    s, ln = res["steady"], res["loop_numbers"]
    rows = []
    for ratio, v in s["loads"].items():
        rows.append([f"{ratio:g}", v["Fz"] / 1e3, v["Calpha"] / 1e3, v["mu"], v["Fmax"] / 1e3,
                     v["coulomb_plateau"] / 1e3, v["coulomb_plateau_error"], v["brush_max_deviation"],
                     v["brush_max_deviation_x"], v["brush_linear_error"]])
    print_table(f"Steady state, DDT at vx = {VX:g} m/s, slip angle 0-{ALPHA_MAX_DEG:g} deg "
                "(Fmax = muY(Fz) Fz; x = Calpha(Fz) tan(alpha)/Fmax):",
                ["Fz/Fz0", "Fz [kN]", "Calpha(Fz) [kN/rad]", "muY(Fz)", "Fmax [kN]", "Coulomb plateau [kN]",
                 "|plateau/Fmax - 1|", "Brush max |F - brush|/Fmax", "at x", "Brush |F/(Calpha tan a) - 1|, x <= 0.2"],
                rows, {1: "{:.1f}", 2: "{:.1f}", 3: "{:.3f}", 4: "{:.3f}", 5: "{:.6f}", 6: "{:.1e}", 7: "{:.5f}",
                       8: "{:.3f}", 9: "{:.1e}"})
    v = s["loads"][1.0]
    print(f"Coulomb plateau = mu Fz: {v['coulomb_plateau']:.6f} N = {v['mu']:g} x {v['Fz']:g} N "
          f"(relative error {v['coulomb_plateau_error']:.1e}; exactly linear below it to "
          f"{v['coulomb_linear_error']:.1e})")
    worst = max(x["brush_max_deviation"] for x in s["loads"].values())
    print(f"Brush max deviation from the brush curve over the sweep: {worst:.5f} Fmax "
          f"(at x = {v['brush_max_deviation_x']:.3f}, alpha = {v['brush_max_deviation_alpha_deg']:.3f} deg at Fz0; "
          "fit bound 0.01304, specification 0.02)")
    print(f"Brush linear up to 0.2 Fmax: |Fy/(Calpha(Fz) tan alpha) - 1| <= "
          f"{max(x['brush_linear_error'] for x in s['loads'].values()):.1e} for x <= 0.2 "
          f"(up to {v['brush_linear_up_to']:.4f} Fmax)")
    print(f"steady state converged: last step changed Fy by <= {s['convergence']:.1e} Fmax")
    d = ln["d"]
    print(f"Standstill loop, {LOOP_MODEL} at vx = 0, vy = +-{LOOP_VY:g} m/s, y = 0 -> +{LOOP_AMPLITUDE:g} -> "
          f"-{LOOP_AMPLITUDE:g} -> +{LOOP_AMPLITUDE:g} Fmax/C_y, {res['loop']['n']} steps per Fmax/C_y "
          f"(Fmax = {ln['Fmax']:g} N, C_y = {ln['C_y']:g} N/m, Fmax/C_y = {1e3 * d:.4f} mm):")
    for law, exact in (("Coulomb", ln["exact_travel"]), ("Brush", ln["Brush_exact_travel"])):
        travels = ln[law]["travel"]
        errs = [abs(tr / exact - 1.0) for tr in travels]
        label = "2 Fmax/C_y" if law == "Coulomb" else "2 x_4 Fmax/C_y"
        print(f"  {law}: reversal travel " + ", ".join(f"{1e3 * tr:.6f} mm" for tr in travels)
              + f" vs exact {label} = {1e3 * exact:.6f} mm (relative error {max(errs):.1e}); "
              f"max |Fy| = {ln[law]['max_abs_Fy']:.6f} N")
    print(f"  Coulomb: first push reaches -Fmax after {1e3 * ln['Coulomb']['first_push_travel']:.6f} mm "
          f"(Fmax/C_y = {1e3 * d:.6f} mm); Unlimited stays on Fy = -C_y y to {ln['Unlimited_stiffness_error']:.1e}")


def write(res: dict, csv_path: Path, loop_csv: Path) -> None:
    cols = ["law", "load_ratio", "Fz", "alpha", "slip", "vy", "Fy", "change", "Calpha", "mu", "Fmax", "x",
            "linear", "coulomb", "brush"]
    header = ["law", "Fz_over_Fz0", "Fz_N", "alpha_rad", "tan_alpha", "vy_m_per_s", "Fy_N",
              "last_step_change_N", "Calpha_Fz_N_per_rad", "muY_Fz", "Fmax_N", "x", "linear_N",
              "coulomb_analytic_N", "brush_curve_N"]
    write_csv(csv_path, header, ([r[c] if isinstance(r[c], str) else float(r[c]) for c in cols]
                                 for r in res["rows"]))
    rows = []
    for law, run in res["loop"]["runs"].items():
        for k in range(len(run["t"])):
            rows.append([law, float(run["t"][k]), float(run["vy"][k]), float(run["y"][k]), float(run["Fy"][k]),
                         float(run["deflY"][k])])
    write_csv(loop_csv, ["law", "time_s", "vy_m_per_s", "y_m", "Fy_N", "deflY_m"], rows)


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_steady(res: dict, path: Path) -> None:
    plt = _plt()
    rows = res["rows"]
    fig = plt.figure(figsize=(15, 10))
    gs = fig.add_gridspec(2, 2, height_ratios=(2.2, 1.0), hspace=0.32, wspace=0.18)
    ax_a = fig.add_subplot(gs[0, 0])
    ax_b = fig.add_subplot(gs[0, 1], sharex=ax_a)
    ax_c = fig.add_subplot(gs[1, :], sharex=ax_a)
    fine = np.radians(np.linspace(0.0, ALPHA_MAX_DEG, 801))

    def sel(law, ratio):
        r = [q for q in rows if q["law"] == law and q["load_ratio"] == ratio]
        return (np.degrees([q["alpha"] for q in r]), np.array([q["Fy"] for q in r]) / 1e3, r)

    # (a) the three laws at Fz0
    L = res["steady"]["loads"][1.0]
    Fmax = L["Fmax"]
    x_fine = L["Calpha"] * np.tan(fine) / Fmax
    for law, style in (("Unlimited", dict(lw=1.6, ls="-.")), ("Coulomb", dict(lw=1.8, ls="-")),
                       ("Brush", dict(lw=1.3, ls="-", marker="o", ms=3.0))):
        a, F, _ = sel(law, 1.0)
        ax_a.plot(a, F, color=COLORS[law], label=f"{law} (FMU)" + (", the default" if law == "Brush" else ""),
                  **style)
    ax_a.plot(np.degrees(fine), Fmax * brush_curve(x_fine) / 1e3, color="black", lw=1.0, ls="--",
              label="brush curve Fmax(3t - 3t² + t³), t = min(1, Cα tan α/(3 Fmax))")
    ax_a.axhline(Fmax / 1e3, color="black", lw=0.8, ls=":")
    ax_a.text(ALPHA_MAX_DEG, Fmax / 1e3 + 0.6, f"Fmax = μ(Fz)·Fz = {Fmax / 1e3:.0f} kN", ha="right",
              va="bottom", fontsize=9)
    ax_a.axhline(0.2 * Fmax / 1e3, color="black", lw=0.6, ls=":")
    a02 = math.degrees(math.atan(0.2 * Fmax / L["Calpha"]))
    ax_a.text(ALPHA_MAX_DEG, 0.2 * Fmax / 1e3 + 0.6, "0.2 Fmax: Brush exactly linear below", ha="right",
              va="bottom", fontsize=9)
    ax_a.annotate(f"α = {a02:.2f}°", xy=(a02, 0.2 * Fmax / 1e3), xytext=(a02 + 1.2, 0.2 * Fmax / 1e3 - 4.0),
                  fontsize=8.5, arrowprops=dict(arrowstyle="-", color="black", lw=0.6))
    ax_a.set_ylim(0, 1.4 * Fmax / 1e3)
    ax_a.set_xlim(0, ALPHA_MAX_DEG)
    ax_a.set(xlabel="slip angle α [deg]   (vy = -vx·tan α)", ylabel="lateral force Fy [kN]",
             title=f"(a) The three friction laws at Fz = Fz0 = {L['Fz'] / 1e3:g} kN\n"
                   f"DDT, vx = {VX:g} m/s, steady state; Cα = {L['Calpha'] / 1e3:g} kN/rad, μY = {L['mu']:g}")
    ax_a.legend(loc="upper left", fontsize=9)

    # (b) load dependence
    for ratio in LOAD_RATIOS:
        Lr = res["steady"]["loads"][ratio]
        c = LOAD_COLORS[ratio]
        xr = Lr["Calpha"] * np.tan(fine) / Lr["Fmax"]
        ax_b.plot(np.degrees(fine), Lr["Fmax"] * brush_curve(xr) / 1e3, color=c, lw=3.0, alpha=0.3)
        ax_b.plot(np.degrees(fine), Lr["Calpha"] * np.tan(fine) / 1e3, color=c, lw=0.8, ls=":")
        a, F, _ = sel("Coulomb", ratio)
        ax_b.plot(a, F, color=c, lw=1.4, ls="--")
        a, F, _ = sel("Brush", ratio)
        ax_b.plot(a, F, color=c, lw=1.4, ls="-", label=f"Fz = {ratio:g} Fz0 = {Lr['Fz'] / 1e3:g} kN: "
                  f"Cα = {Lr['Calpha'] / 1e3:.0f} kN/rad, μ = {Lr['mu']:.2f}, Fmax = {Lr['Fmax'] / 1e3:.0f} kN")
    top = 1.25 * res["steady"]["loads"][LOAD_RATIOS[-1]]["Fmax"] / 1e3
    ax_b.set_ylim(0, top)
    from matplotlib.lines import Line2D

    style_keys = [Line2D([], [], color="0.3", lw=1.4, ls="-", label="Brush (FMU)"),
                  Line2D([], [], color="0.3", lw=1.4, ls="--", label="Coulomb (FMU)"),
                  Line2D([], [], color="0.3", lw=2.8, alpha=0.3, label="brush curve (analytic)"),
                  Line2D([], [], color="0.3", lw=0.8, ls=":", label="Unlimited Cα(Fz)·tan α")]
    leg1 = ax_b.legend(loc="upper left", fontsize=8.5, title="load (colour)", title_fontsize=9)
    ax_b.add_artist(leg1)
    ax_b.legend(handles=style_keys, loc="lower right", fontsize=8.5, title="law (line style)", title_fontsize=9)
    ax_b.set(xlabel="slip angle α [deg]", ylabel="lateral force Fy [kN]",
             title="(b) Load dependence: Cα(Fz) (slope at 0) and μ(Fz)·Fz (plateau)\n"
                   "Cα(Fz) = Cα·x(1 + 1/c2²)/(1 + x²/c2²), μ(Fz) = μ(1 - 0.1(x - 1)), x = Fz/Fz0")

    # (c) deviation of the Brush fit from the brush curve
    for ratio in LOAD_RATIOS:
        _, _, r = sel("Brush", ratio)
        a = np.degrees([q["alpha"] for q in r])
        dev = np.array([(q["Fy"] - q["brush"]) / q["Fmax"] for q in r])
        ax_c.plot(a, 100 * dev, color=LOAD_COLORS[ratio], lw=1.3, marker="o", ms=2.5, label=f"Fz = {ratio:g} Fz0")
    worst = max(v["brush_max_deviation"] for v in res["steady"]["loads"].values())
    for sgn in (1, -1):
        ax_c.axhline(sgn * 2.0, color="black", lw=0.8, ls="--")
        ax_c.axhline(sgn * 100 * worst, color="black", lw=0.6, ls=":")
    ax_c.text(ALPHA_MAX_DEG - 0.1, 2.05, "specified bound ±2 % Fmax", ha="right", va="bottom", fontsize=8.5)
    ax_c.text(ALPHA_MAX_DEG - 0.1, 100 * worst + 0.05, f"max {100 * worst:.2f} % Fmax (at x = 0.2)", ha="right",
              va="bottom", fontsize=8.5)
    ax_c.set_ylim(-2.6, 2.6)
    ax_c.set(xlabel="slip angle α [deg]", ylabel="(Fy - brush curve)/Fmax [%]",
             title="(c) Brush law (four spring-slider branches) minus the analytic brush curve")
    ax_c.legend(loc="lower right", fontsize=8.5, ncol=3)
    for ax in (ax_a, ax_b, ax_c):
        ax.grid(True, alpha=0.3)
    fig.suptitle("TireLag friction limit: steady-state lateral force against slip angle", fontsize=14)
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)


def plot_loop(res: dict, path: Path) -> None:
    plt = _plt()
    loop, ln = res["loop"], res["loop_numbers"]
    Fmax, d = loop["Fmax"], loop["d"]
    fig = plt.figure(figsize=(15, 8))
    gs = fig.add_gridspec(2, 2, width_ratios=(1.45, 1.0), hspace=0.3, wspace=0.2)
    ax = fig.add_subplot(gs[:, 0])
    ax_y = fig.add_subplot(gs[0, 1])
    ax_f = fig.add_subplot(gs[1, 1], sharex=ax_y)
    styles = {"Unlimited": dict(lw=1.2, ls="-"), "Coulomb": dict(lw=2.2, ls="-"), "Brush": dict(lw=1.8, ls="--")}
    labels = {"Unlimited": "Unlimited: elastic line Fy = -C_y·y",
              "Coulomb": "Coulomb: elastic-plastic (slope C_y, plateaus ±Fmax)",
              "Brush": "Brush: four branches slide one after another\n"
                       f"(full swing after 2·{BRUSH_BREAKPOINTS[-1]:.2f}·Fmax/C_y)"}
    for law in LAWS:
        run = loop["runs"][law]
        ax.plot(1e3 * run["y"], run["Fy"] / 1e3, color=COLORS[law], label=labels[law], **styles[law])
        ax_f.plot(run["t"], run["Fy"] / 1e3, color=COLORS[law], label=law, **styles[law])
    run = loop["runs"]["Coulomb"]
    ax_y.plot(run["t"], 1e3 * run["y"], color="black", lw=1.3)
    for sgn in (1, -1):
        ax.axhline(sgn * Fmax / 1e3, color="black", lw=0.7, ls=":")
        ax_f.axhline(sgn * Fmax / 1e3, color="black", lw=0.7, ls=":")
    ax.text(-LOOP_AMPLITUDE * d * 1e3, Fmax / 1e3 + 1.5, f"+Fmax = μ·Fz = {Fmax / 1e3:.0f} kN", fontsize=9)
    ax.text(LOOP_AMPLITUDE * d * 1e3, -Fmax / 1e3 - 1.5, f"-Fmax", fontsize=9, ha="right", va="top")
    # the reversal travel 2 Fmax/C_y on the Coulomb loop (first reversal, at y = +A)
    rev = ln["Coulomb"]["reversals"][0]
    y0, y1 = 1e3 * rev["y_reversal"], 1e3 * rev["y_limit"]
    level = (Fmax / 1e3) * 1.22
    ax.annotate("", xy=(y1, level), xytext=(y0, level),
                arrowprops=dict(arrowstyle="<->", color="tab:blue", lw=1.3))
    ax.text((y0 + y1) / 2, level + 1.0, f"reversal: 2·Fmax/C_y = {2 * d * 1e3:.1f} mm",
            ha="center", va="bottom", color="tab:blue", fontsize=9.5)
    for yy in (y0, y1):
        ax.plot([yy, yy], [level, -Fmax / 1e3 if yy == y0 else Fmax / 1e3], color="tab:blue", lw=0.6, ls=":")
    # direction arrows on the Coulomb loop
    for (ya, Fa), (yb, Fb) in (((0.5 * d, -Fmax), (1.2 * d, -Fmax)), ((-0.6 * d, Fmax), (-1.3 * d, Fmax))):
        ax.annotate("", xy=(1e3 * yb, Fb / 1e3), xytext=(1e3 * ya, Fa / 1e3),
                    arrowprops=dict(arrowstyle="-|>", color="tab:blue", lw=1.5))
    ax.set_ylim(-1.5 * Fmax / 1e3, 1.5 * Fmax / 1e3)
    ax.set_xlim(-1.08e3 * LOOP_AMPLITUDE * d, 1.08e3 * LOOP_AMPLITUDE * d)
    ax.set(xlabel="lateral wheel displacement y = ∫vy dt [mm]", ylabel="lateral force on the hub Fy [kN]",
           title=f"(a) Force-displacement loop at standstill ({LOOP_MODEL}, vx = 0, Fz = Fz0)\n"
                 f"pushed 0 → +{LOOP_AMPLITUDE:g} → -{LOOP_AMPLITUDE:g} → +{LOOP_AMPLITUDE:g} Fmax/C_y "
                 f"(±{1e3 * LOOP_AMPLITUDE * d:.0f} mm) at |vy| = {LOOP_VY:g} m/s")
    ax.legend(loc="lower left", fontsize=9)
    ax_y.set(ylabel="y [mm]", title="(b) Prescribed motion: push, reverse, push back")
    ax_f.set(xlabel="time t [s]", ylabel="Fy [kN]", title="(c) Lateral force")
    ax_f.set_ylim(-1.5 * Fmax / 1e3, 1.5 * Fmax / 1e3)
    ax_f.legend(loc="lower right", fontsize=8.5, ncol=3)
    for a in (ax, ax_y, ax_f):
        a.grid(True, alpha=0.3)
    fig.suptitle(f"TireLag friction limit at standstill: stick, slide and reversal without wind-up "
                 f"(C_y = Cα/σY = {loop['C_y'] / 1e3:g} kN/m, Fmax/C_y = {1e3 * d:.1f} mm)", fontsize=13)
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)


def main(argv=None) -> dict:
    p = parser(__doc__.split("\n\n")[0])
    p.add_argument("--docs", action="store_true",
                   help="also copy the two PNGs to docs/ in the project (the README's figures)")
    args = p.parse_args(argv)
    res = simulate(args.fmu, args.quick)
    png, csv_path = output_paths(args.out_dir, NAME)
    loop_png, loop_csv = output_paths(args.out_dir, LOOP_NAME)
    report(res)
    write(res, csv_path, loop_csv)
    plot_steady(res, png)
    plot_loop(res, loop_png)
    print(f"wrote {png}\nwrote {loop_png}\nwrote {csv_path}\nwrote {loop_csv}")
    if args.docs:
        DOCS.mkdir(exist_ok=True)
        for src in (png, loop_png):
            shutil.copyfile(src, DOCS / src.name)
            print(f"copied {src.name} to {DOCS / src.name}")
    res["paths"] = {"png": png, "csv": csv_path, "loop_png": loop_png, "loop_csv": loop_csv}
    return res


if __name__ == "__main__":
    main()
