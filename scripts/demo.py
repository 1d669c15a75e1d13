#!/usr/bin/env python3
"""TireLag demo: the four tire-lag models side by side, at 0, 0.5 and 20 m/s, and the
friction limit.

Two frequency sweeps (linear chirps, 0.1 Hz -> 3 Hz over 10 s), each run for every
model and speed with fmpy's FMU2Slave (FMU3Slave for the FMI 3.0 FMU):

  lateral  The wheel hub is shaken sideways, y(t) = Y sin(phi(t)), Y = 10 mm, no steering:
           vy = dy/dt, steerRate = 0. At 0 m/s the tire is a spring (RLT: Fy = -C_y y,
           undamped) or a spring-damper (DDT, SecondOrder, RingBody). At 20 m/s every model
           is close to the first-order lag Fy/alpha = Calpha/(1 + s sigmaY/|vx|).
  steer    The wheel is steered about its vertical axis, delta(t) = D sin(phi(t)),
           D = 1 deg, while the hub moves straight ahead at vx: steerRate = d(delta)/dt,
           vy = -vx sin(delta) (the hub velocity seen in the steered wheel frame).
           At 0 m/s only DDT has a yaw spring-damper and so a steering moment Mz; at speed
           the slip angle alpha = delta gives Fy and the trail moment -trail*Fy.

The sweeps stay below 0.2 Fmax (Fmax = muY(Fz) Fz = 40 kN at the defaults), where the
default friction law, Brush, is exactly the linear model. Two more scenarios reach the
friction limit (docs/specification.md 4c), each run with the default tire (DDT) and the default law
(Brush), and with friction = Unlimited (the linear tire) for comparison:

  steerRamp  at vx = 10 m/s the wheel is steered slowly from 0 to 20 deg and back
             (delta(t) a triangle over 10 s; steerRate = d(delta)/dt, vy = -vx sin(delta)):
             Brush follows the brush curve up to Fy = Fmax; the linear tire goes on to
             about Calpha sin(20 deg) = 120 kN.
  push       at vx = 0 the hub is pushed sideways, y(t) = 0 -> +0.3 m -> -0.3 m -> 0
             (a triangle, vy = dy/dt = +-0.12 m/s): the force-displacement loop of stick
             and slide, with plateaus at +-Fmax; the linear tire is a spring-damper.

The inputs are given at every communication point (10 ms) together with their time
derivatives (fmi2SetRealInputDerivatives), so the FMU integrates exactly the piecewise
linear input between the points. The FMI 3.0 FMU has no input derivatives: there each
step holds the mean of the input's two point values, which moves the hub (the integral of
vy) by exactly as much as the ramp. The forces differ from the ramp's by O(h^2): with these
10 ms steps by up to 0.3 % of the peak for RLT and DDT, and up to 4 % for SecondOrder and
RingBody, whose carcass dampers pass the held input's jump at every step straight to the
fast contact (ring) mass.

Writes (relative to the repository root, or to --out-dir):

  out/demo.csv  long format, one row per scenario, model, friction law, speed and time
                point. Columns: scenario (lateral|steer|steerRamp|push),
                model (RLT|DDT|SecondOrder|RingBody), friction (Brush|Unlimited), time [s],
                hubY [m] (hub displacement of the lateral sweep and the push, else 0),
                steer [rad] (steer angle of the steer sweep and the steer ramp, else 0),
                then the FMU inputs vx [m/s], vy [m/s], steerRate [rad/s], vsx [m/s], Fz [N]
                and all FMU outputs Fx [N], Fy [N], Mz [N.m], My [N.m], alphaT [rad],
                kappaT [1], deflX [m], deflY [m], deflPsi [rad].
  out/demo.png  top row: the input chirps; then one row per speed (0, 0.5, 20 m/s) with
                Fy(t) and the force-displacement loop Fy vs y of the lateral sweep, and
                Fy(t) and Mz(t) of the steer sweep; one line per model. A straight line in
                the loop is a lossless spring (RLT at 0 m/s), an ellipse a damped one.
                Bottom row, the friction limit (DDT, Brush against Unlimited): Fy(t) and
                Fy against the steer angle in the steer ramp, Fy(t) and Fy against the
                hub displacement in the standstill push.

Usage: .venv/bin/python scripts/demo.py [FMU] [--out-dir DIR]
       (FMU: target/fmu/TireLag.fmu, the default, or target/fmu/fmi3/TireLag.fmu)
"""

from __future__ import annotations

import argparse
import csv
import shutil
import sys
import time
from pathlib import Path

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from fmpy import extract, read_model_description  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "examples"))
from cosim.fmi import FMI2, Slave, fmi_version, start_values  # noqa: E402  (either FMU, FMI 2.0 or 3.0)

MODELS = {"RLT": 1, "DDT": 2, "SecondOrder": 3, "RingBody": 4}
SPEEDS = (0.0, 0.5, 20.0)  # vx, m/s
STOP_TIME = 10.0  # s
STEP = 0.01  # communication step, s
F_START, F_END = 0.1, 3.0  # chirp frequencies, Hz
HUB_AMPLITUDE = 0.010  # lateral sweep: hub displacement amplitude Y, m
STEER_AMPLITUDE = np.deg2rad(1.0)  # steer sweep: steer angle amplitude D, rad
# The friction-limit scenarios: the default tire model and law, and the linear tire.
LIMIT_MODEL = "DDT"
FRICTION_LAWS = {"Unlimited": 1, "Coulomb": 2, "Brush": 3}
LIMIT_LAWS = ("Brush", "Unlimited")
RAMP_SPEED = 10.0  # steerRamp: vx, m/s
RAMP_PEAK = np.deg2rad(20.0)  # steerRamp: largest steer angle, rad (reached at STOP_TIME/2)
PUSH_PEAK = 0.3  # push: largest hub displacement, m (reached at STOP_TIME/4, 3 STOP_TIME/4)
LIMIT_STYLE = {"Brush": ("tab:red", "-"), "Unlimited": ("0.45", "--")}

INPUTS = ("vx", "vy", "steerRate", "vsx", "Fz")
OUTPUTS = ("Fx", "Fy", "Mz", "My", "alphaT", "kappaT", "deflX", "deflY", "deflPsi")
STYLE = {  # colour and dash per model, so that overlapping curves stay visible
    "RLT": ("tab:blue", "-"),
    "DDT": ("tab:orange", "--"),
    "SecondOrder": ("tab:green", "-."),
    "RingBody": ("tab:red", ":"),
}


def chirp(t: np.ndarray, amplitude: float):
    """Linear chirp a sin(phi(t)), f(t) = F_START + (F_END - F_START) t / STOP_TIME.

    Returns the signal and its exact time derivative."""
    rate = (F_END - F_START) / STOP_TIME
    phase = 2 * np.pi * (F_START * t + 0.5 * rate * t**2)
    omega = 2 * np.pi * (F_START + rate * t)
    return amplitude * np.sin(phase), amplitude * omega * np.cos(phase)


def frequency(t):
    return F_START + (F_END - F_START) * np.asarray(t) / STOP_TIME


def scenario_inputs(scenario: str, vx: float, t: np.ndarray) -> dict[str, np.ndarray]:
    """The prescribed motion and the FMU inputs at the time points t."""
    zero = np.zeros_like(t)
    if scenario == "lateral":
        hub_y, vy = chirp(t, HUB_AMPLITUDE)
        return {"hubY": hub_y, "steer": zero, "vy": vy, "steerRate": zero}
    if scenario == "steer":
        steer, steer_rate = chirp(t, STEER_AMPLITUDE)
        return {"hubY": zero, "steer": steer, "vy": -vx * np.sin(steer), "steerRate": steer_rate}
    if scenario == "steerRamp":
        steer, steer_rate = triangle(t, RAMP_PEAK, (0.0, 0.5, 1.0), (0.0, 1.0, 0.0))
        return {"hubY": zero, "steer": steer, "vy": -vx * np.sin(steer), "steerRate": steer_rate}
    if scenario == "push":
        hub_y, vy = triangle(t, PUSH_PEAK, (0.0, 0.25, 0.75, 1.0), (0.0, 1.0, -1.0, 0.0))
        return {"hubY": hub_y, "steer": zero, "vy": vy, "steerRate": zero}
    raise ValueError(scenario)


def triangle(t: np.ndarray, peak: float, knots, values):
    """The piecewise linear signal through (knots * STOP_TIME, values * peak), and its
    slope (at a knot, the slope of the piece that starts there)."""
    x = np.asarray(knots) * STOP_TIME
    y = np.asarray(values) * peak
    slopes = np.diff(y) / np.diff(x)
    piece = np.clip(np.searchsorted(x, t, side="right") - 1, 0, len(slopes) - 1)
    return np.interp(t, x, y), slopes[piece]


class TireFmu:
    """The extracted FMU (FMI 2.0 or 3.0) and its value references, looked up by name."""

    def __init__(self, fmu_path: Path):
        self.path = fmu_path
        self.description = read_model_description(str(fmu_path))
        self.fmi_version = fmi_version(self.description, fmu_path)
        self.unzipdir = extract(str(fmu_path))
        self.vr = {v.name: v.valueReference for v in self.description.modelVariables}
        missing = [n for n in INPUTS + OUTPUTS + ("tireModel", "friction") if n not in self.vr]
        if missing:
            raise SystemExit(f"{fmu_path}: the model description lacks {missing}")

    def close(self):
        shutil.rmtree(self.unzipdir, ignore_errors=True)

    def simulate(self, model: str, vx: float, t: np.ndarray, u: dict[str, np.ndarray],
                 friction: str = "Brush") -> dict:
        """One run of the FMU: vy and steerRate follow u (ramped exactly between the
        points t), vx is held, vsx = 0, Fz at its start value (the nominal load);
        friction is the law of docs/specification.md 4c (Brush, the FMU's default, unless told). FMI 3.0:
        each step holds the mean of the two point values instead of the ramp."""
        vr = self.vr
        with Slave(self.description, self.unzipdir, f"{model}_{friction}_{vx:g}", self.path) as slave:
            slave.set_selector([vr["tireModel"], vr["friction"]], [MODELS[model], FRICTION_LAWS[friction]])
            slave.initialize(start_time=float(t[0]), stop_time=float(t[-1]))

            ramped = [vr["vy"], vr["steerRate"]]
            out_vrs = [vr[name] for name in OUTPUTS + ("Fz",)]
            slave.set_real([vr["vx"]], [vx])
            result = np.empty((len(t), len(out_vrs)))
            for k in range(len(t)):
                start = [u["vy"][k], u["steerRate"][k]]
                slave.set_real(ramped, start)
                result[k] = slave.get_real(out_vrs)
                if k + 1 == len(t):
                    break
                h = t[k + 1] - t[k]
                end = [u["vy"][k + 1], u["steerRate"][k + 1]]
                if slave.has_input_derivatives:
                    slave.ramp_inputs(ramped, [(b - a) / h for a, b in zip(start, end)])
                else:
                    slave.set_real(ramped, [0.5 * (a + b) for a, b in zip(start, end)])
                slave.do_step(t[k], h)
        columns = {name: result[:, i] for i, name in enumerate(OUTPUTS + ("Fz",))}
        columns.update(vx=np.full_like(t, vx), vsx=np.zeros_like(t))
        return columns


def run_all(fmu: TireFmu, t: np.ndarray) -> list[dict]:
    runs = []
    for scenario in ("lateral", "steer"):
        for vx in SPEEDS:
            u = scenario_inputs(scenario, vx, t)
            for model in MODELS:
                y = fmu.simulate(model, vx, t, u)
                runs.append({"scenario": scenario, "model": model, "friction": "Brush", "speed": vx, **u, **y})
    for scenario, vx in (("steerRamp", RAMP_SPEED), ("push", 0.0)):
        u = scenario_inputs(scenario, vx, t)
        for law in LIMIT_LAWS:
            y = fmu.simulate(LIMIT_MODEL, vx, t, u, friction=law)
            runs.append({"scenario": scenario, "model": LIMIT_MODEL, "friction": law, "speed": vx, **u, **y})
    return runs


def write_csv(path: Path, t: np.ndarray, runs: list[dict]):
    columns = ("hubY", "steer") + INPUTS + OUTPUTS
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(("scenario", "model", "friction", "time") + columns)
        for run in runs:
            data = np.column_stack([t] + [run[c] for c in columns])
            for row in data:
                writer.writerow([run["scenario"], run["model"], run["friction"]] + [f"{v:.10g}" for v in row])


def find(runs, scenario, vx, model, friction="Brush"):
    return next(r for r in runs if r["scenario"] == scenario and r["speed"] == vx and r["model"] == model
                and r["friction"] == friction)


def friction_limit(description, Fz: float) -> float:
    """Fmax = muY(Fz) Fz, muY(Fz) = muY max(0, 1 + muLoadSensitivity (Fz/Fz0 - 1)) (docs/specification.md 4c)."""
    start = start_values(description)
    mu = start["muY"] * max(0.0, 1.0 + start["muLoadSensitivity"] * (Fz / start["Fz0"] - 1.0))
    return mu * Fz


LOOP_WINDOW = 1.0  # s: the force-displacement loops show the last second (~2.7-3 Hz)


def plot(path: Path, t: np.ndarray, runs: list[dict], calpha: float, fmax: float):
    fig, axes = plt.subplots(len(SPEEDS) + 2, 4, figsize=(20, 16.5))
    limit_row = len(SPEEDS) + 1
    time_axes = [ax for ax in axes.flat if ax not in axes[1:, 1] and ax is not axes[limit_row, 3]]
    for ax in time_axes[1:]:
        ax.sharex(time_axes[0])

    # Row 0: the prescribed motions, with the chirp frequency on a top axis.
    hub_y, hub_vy = chirp(t, HUB_AMPLITUDE)
    steer, steer_rate = chirp(t, STEER_AMPLITUDE)
    inputs = (
        (1e3 * hub_y, "hub lateral displacement y [mm]", "Lateral sweep: hub motion y(t)"),
        (hub_vy, "vy = dy/dt [m/s]", "Lateral sweep: input vy (steerRate = 0)"),
        (np.rad2deg(steer), "steer angle δ [deg]", "Steer sweep: δ(t), input vy = -vx·sin δ"),
        (np.rad2deg(steer_rate), "steerRate = dδ/dt [deg/s]", "Steer sweep: input steerRate"),
    )
    for ax, (signal, unit, title) in zip(axes[0], inputs):
        ax.plot(t, signal, color="black", lw=1)
        ax.set(ylabel=unit, title=title)
        top = ax.secondary_xaxis(
            "top",
            functions=(frequency, lambda f: (np.asarray(f) - F_START) * STOP_TIME / (F_END - F_START)),
        )
        top.set_xlabel("chirp frequency [Hz]")

    panels = (  # (scenario, output, scale, unit label, panel title)
        ("lateral", "Fy", 1e-3, "Fy [kN]", "lateral sweep: Fy(t)"),
        ("lateral", "loop", 1e-3, "Fy [kN]", f"lateral sweep: Fy vs y, last {LOOP_WINDOW:g} s "
         f"({frequency(STOP_TIME - LOOP_WINDOW):.1f}–{F_END:g} Hz)"),
        ("steer", "Fy", 1e-3, "Fy [kN]", "steer sweep: Fy(t)"),
        ("steer", "Mz", 1.0, "Mz [N·m]", "steer sweep: Mz(t)"),
    )
    window = t >= STOP_TIME - LOOP_WINDOW - 1e-9
    for row, vx in enumerate(SPEEDS, start=1):
        for col, (scenario, output, scale, unit, title) in enumerate(panels):
            ax = axes[row, col]
            peak = 0.0
            for model in MODELS:
                run = find(runs, scenario, vx, model)
                colour, dash = STYLE[model]
                if output == "loop":
                    ax.plot(1e3 * run["hubY"][window], scale * run["Fy"][window],
                            color=colour, ls=dash, lw=1.3, label=model)
                    continue
                ax.plot(t, scale * run[output], color=colour, ls=dash, lw=1.3, label=model)
                peak = max(peak, np.max(np.abs(run[output])))
            if output == "loop":
                ax.set_xlabel("hub lateral displacement y [mm]")
            elif output == "Fy" and vx > 0:
                # Steady-state (no-lag) force Calpha * alpha, alpha = -vy/|vx|, drawn when
                # it fits the panel's scale.
                vy = find(runs, scenario, vx, "RLT")["vy"]
                quasi_static = calpha * (-vy / abs(vx))
                if np.max(np.abs(quasi_static)) <= 3 * peak:
                    ax.plot(t, scale * quasi_static, color="black", lw=0.8, alpha=0.6,
                            label="steady state Cα·α (no lag)")
            if output != "loop" and peak < 1e-9:
                ax.text(0.5, 0.75, f"{output} = 0 for every model", transform=ax.transAxes,
                        ha="center", va="center", fontsize=11,
                        bbox=dict(facecolor="white", edgecolor="none"))
                ax.set_ylim(-1, 1)
            ax.set_title(f"vx = {vx:g} m/s, {title}")
            ax.set_ylabel(unit)
    plot_limit_row(axes[limit_row], t, runs, calpha, fmax)
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
    for ax in (axes[limit_row - 1, 0], axes[limit_row - 1, 2], axes[limit_row - 1, 3],
               axes[limit_row, 0], axes[limit_row, 2]):
        ax.set_xlabel("time t [s]")

    handles, labels = [], []
    for ax in axes[:limit_row].flat:  # one legend entry per distinct line label (the sweeps)
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=12, frameon=True)
    fig.suptitle(
        f"TireLag, default parameters: four tire-lag models under a {F_START:g}→{F_END:g} Hz chirp "
        f"(lateral hub shake ±{1e3 * HUB_AMPLITUDE:g} mm; steering ±{np.rad2deg(STEER_AMPLITUDE):g}° "
        "while the hub moves straight at vx);\nbottom row: the friction limit of the default tire "
        f"(DDT, Brush) against the linear tire (Unlimited), Fmax = μY(Fz)·Fz = {fmax / 1e3:g} kN",
        fontsize=13,
    )
    fig.tight_layout(rect=(0, 0.025, 1, 0.985))
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_limit_row(axes, t, runs, calpha, fmax):
    """The friction limit: Brush (the default law) against Unlimited, default tire (DDT)."""
    ax_ft, ax_fd, ax_pt, ax_py = axes
    for law in LIMIT_LAWS:
        colour, dash = LIMIT_STYLE[law]
        label = f"{LIMIT_MODEL}, friction = {law}" + (" (default)" if law == "Brush" else " (linear tire)")
        ramp = find(runs, "steerRamp", RAMP_SPEED, LIMIT_MODEL, law)
        push = find(runs, "push", 0.0, LIMIT_MODEL, law)
        ax_ft.plot(t, 1e-3 * ramp["Fy"], color=colour, ls=dash, lw=1.6, label=label)
        ax_fd.plot(np.rad2deg(ramp["steer"]), 1e-3 * ramp["Fy"], color=colour, ls=dash, lw=1.6)
        ax_pt.plot(t, 1e-3 * push["Fy"], color=colour, ls=dash, lw=1.6)
        ax_py.plot(1e3 * push["hubY"], 1e-3 * push["Fy"], color=colour, ls=dash, lw=1.6)
    # the brush curve Fmax (3t - 3t^2 + t^3), t = min(1, Calpha |alpha| / (3 Fmax)), alpha = sin(delta)
    delta = np.linspace(0.0, RAMP_PEAK, 200)
    tt = np.minimum(1.0, calpha * np.sin(delta) / (3.0 * fmax))
    ax_fd.plot(np.rad2deg(delta), 1e-3 * fmax * (3 * tt - 3 * tt**2 + tt**3), color="black", lw=0.9, ls=":",
               label="brush curve Fmax(3τ - 3τ² + τ³) (steady state)")
    for ax in axes:
        for sign in (1, -1) if ax in (ax_pt, ax_py) else (1,):
            ax.axhline(sign * 1e-3 * fmax, color="black", lw=0.8, alpha=0.6, ls="-.",
                       label="±Fmax = μY(Fz)·Fz" if sign == 1 else None)
        ax.set_ylabel("Fy [kN]")
    ax_ft.set_ylim(-5, 1e-3 * calpha * np.sin(RAMP_PEAK) * 1.08)
    ax_fd.set_ylim(ax_ft.get_ylim())
    ax_ft.set_title(f"vx = {RAMP_SPEED:g} m/s, steer ramp δ = 0→{np.rad2deg(RAMP_PEAK):g}°→0: Fy(t)")
    ax_fd.set_title(f"vx = {RAMP_SPEED:g} m/s, steer ramp: Fy vs steer angle δ")
    ax_fd.set_xlabel("steer angle δ [deg]  (slip angle α = sin δ)")
    ax_ft.legend(loc="upper left", fontsize=9)
    ax_fd.legend(loc="upper left", fontsize=9)
    ax_pt.set_title(f"vx = 0, hub pushed y = 0→+{PUSH_PEAK:g}→-{PUSH_PEAK:g}→0 m: Fy(t)")
    ax_py.set_title("vx = 0, push: Fy vs hub displacement y")
    ax_py.set_xlabel("hub lateral displacement y [mm]")
    unlimited = np.max(np.abs(find(runs, "push", 0.0, LIMIT_MODEL, "Unlimited")["Fy"]))
    for ax in (ax_pt, ax_py):
        ax.set_ylim(-1.5e-3 * fmax, 1.5e-3 * fmax)
        ax.text(0.98, 0.03, f"Unlimited peaks at ±{unlimited / 1e3:.0f} kN (off scale)", transform=ax.transAxes,
                ha="right", va="bottom", fontsize=9, color="0.3", bbox=dict(facecolor="white", edgecolor="none"))


def limit_summary(t, runs, fmax: float) -> str:
    """One line on the friction limit: where Brush saturates, what the linear tire gives."""
    peak = {(s, law): np.max(np.abs(find(runs, s, vx, LIMIT_MODEL, law)["Fy"]))
            for s, vx in (("steerRamp", RAMP_SPEED), ("push", 0.0)) for law in LIMIT_LAWS}
    chirps = max(np.max(np.abs(r["Fy"])) for r in runs if r["scenario"] in ("lateral", "steer"))
    return (f"friction limit: Fy saturates at muY(Fz) Fz = {fmax / 1e3:.1f} kN with Brush (peak "
            f"{peak['steerRamp', 'Brush'] / 1e3:.1f} kN in the {np.rad2deg(RAMP_PEAK):g} deg steer ramp at "
            f"{RAMP_SPEED:g} m/s, {peak['push', 'Brush'] / 1e3:.1f} kN in the standstill push); the linear "
            f"(Unlimited) tire would give {peak['steerRamp', 'Unlimited'] / 1e3:.1f} kN and "
            f"{peak['push', 'Unlimited'] / 1e3:.1f} kN. (The chirps peak at {chirps / fmax:.2f} Fmax: "
            "below 0.2 Fmax Brush is exactly linear.)")


def summary(t, runs):
    """Printed table: peak |Fy| (lateral sweep) and peak |Mz| (steer sweep)."""
    late = t >= STOP_TIME - 1.0
    lines = [
        "peak |Fy| in the lateral sweep [N] (whole run / last 1 s, 2.7-3 Hz) and "
        "peak |Mz| in the steer sweep [N.m]:",
        f"  {'vx [m/s]':>8}  {'model':<12} {'Fy':>9} {'Fy 3Hz':>9} {'Mz':>9}",
    ]
    for vx in SPEEDS:
        for model in MODELS:
            fy = find(runs, "lateral", vx, model)["Fy"]
            mz = find(runs, "steer", vx, model)["Mz"]
            lines.append(
                f"  {vx:>8g}  {model:<12} {np.max(np.abs(fy)):>9.0f} "
                f"{np.max(np.abs(fy[late])):>9.0f} {np.max(np.abs(mz)):>9.1f}"
            )
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("fmu", nargs="?", type=Path, default=REPO / "target" / "fmu" / "TireLag.fmu",
                        help="the FMU: FMI 2.0 (default: target/fmu/TireLag.fmu in the repository) "
                             "or FMI 3.0 (target/fmu/fmi3/TireLag.fmu)")
    parser.add_argument("--out-dir", type=Path, default=REPO / "out",
                        help="where demo.csv and demo.png go (default: out/ in the repository)")
    args = parser.parse_args(argv)
    if not args.fmu.is_file():
        sys.exit(f"demo: no FMU at {args.fmu}; build it with ./scripts/build-fmu (or run ./scripts/demo)")
    args.out_dir.mkdir(parents=True, exist_ok=True)

    started = time.perf_counter()
    t = np.round(np.arange(0.0, STOP_TIME + STEP / 2, STEP), 12)
    fmu = TireFmu(args.fmu)
    try:
        runs = run_all(fmu, t)
        calpha = start_values(fmu.description)["Calpha"]
        fmax = friction_limit(fmu.description, float(find(runs, "push", 0.0, LIMIT_MODEL)["Fz"][0]))
    finally:
        fmu.close()
    elapsed = time.perf_counter() - started

    csv_path = args.out_dir / "demo.csv"
    png_path = args.out_dir / "demo.png"
    write_csv(csv_path, t, runs)
    plot(png_path, t, runs, float(calpha), fmax)

    inputs = ("inputs ramped exactly (fmi2SetRealInputDerivatives)" if fmu.fmi_version == FMI2
              else "inputs held at each step's mean (FMI 3.0 has no input derivatives)")
    print(f"FMU: {args.fmu} (FMI {fmu.fmi_version}; {inputs})")
    print(f"simulated {len(runs)} runs (2 sweeps x {len(SPEEDS)} speeds x {len(MODELS)} models, and "
          f"2 friction-limit scenarios x {len(LIMIT_LAWS)} laws), "
          f"{len(t) - 1} steps of {STEP:g} s each, in {elapsed:.2f} s")
    print(summary(t, runs))
    print(limit_summary(t, runs, fmax))
    print(f"CSV: {csv_path.resolve()}")
    print(f"PNG: {png_path.resolve()}")


if __name__ == "__main__":
    main()
