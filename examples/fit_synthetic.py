"""Fitting tire parameters to measurements, on data synthesised from known parameters.

Three standard experiments, each run on the FMU (fmpy, Co-Simulation) with parameters that
differ from the FMU's defaults, sampled every 10 ms with Gaussian measurement noise, written
as a CSV and fitted back with ./scripts/fit (the FMU's exact step, bounded least squares):

- step_steer: RLT rolling at 10 m/s, vy steps to -0.2 m/s and back: Calpha and sigmaY
  (Kim fits an equivalent cornering stiffness and a time lag to road tests this way).
- swept_sine: DDT rolling at 3 m/s, vy swept 0.2-5 Hz: Calpha, sigmaY and dampingY.
- standstill_snake: DDT at standstill steered +-40 deg at 0.2 Hz with the Coulomb law
  (the wheel-loader test): the yaw set stiffnessPsi, dampingPsi and the friction plateau
  boreRadius muY Fz, here through boreRadius.
- friction_plateau: RLT rolling at 10 m/s with Coulomb, the slip ramped into saturation:
  muY with Calpha.

    .venv/bin/python examples/fit_synthetic.py [--out out/fit] [--seed 1] [--fmu FMU]

prints each parameter's truth, estimate and 95 % interval, and writes each experiment's
CSV, fit files and PNG below --out. The data come from either FMU (--fmu: the FMI 2.0
target/fmu/TireLag.fmu, the default, or the FMI 3.0 target/fmu/fmi3/TireLag.fmu; the
inputs are held over each step, so the two give the same data); ./scripts/fit fits them
with its own exact step.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "examples"))
from cosim.fmi import FMU2_PATH as FMU, Slave  # noqa: E402  (either FMU, FMI 2.0 or 3.0)

INPUTS = ["vx", "vy", "steerRate", "vsx", "Fz"]
MODELS = {"RLT": 1, "DDT": 2, "SecondOrder": 3, "RingBody": 4}
LAWS = {"Unlimited": 1, "Coulomb": 2, "Brush": 3}
H = 0.01


def step_steer(t):
    vy = np.where((t >= 0.5) & (t < 3.0), -0.2, 0.0)
    return {"vx": np.full_like(t, 10.0), "vy": vy}


def swept_sine(t):
    f = 0.2 + (5.0 - 0.2) * t / t[-1]
    phase = 2 * np.pi * np.cumsum(f) * (t[1] - t[0])
    return {"vx": np.full_like(t, 3.0), "vy": 0.05 * np.sin(phase)}


def standstill_snake(t):
    # steer angle 40 deg sin(2 pi 0.2 t): its rate
    return {"steerRate": np.radians(40.0) * 2 * np.pi * 0.2 * np.cos(2 * np.pi * 0.2 * t)}


def friction_plateau(t):
    alpha = np.minimum(t, 2.0) * 0.15      # slip angle ramped to 0.3 rad: saturated from 0.7 s
    return {"vx": np.full_like(t, 10.0), "vy": -10.0 * np.tan(alpha)}


# name: (model, law, duration, inputs, true parameters, free, noise (N or N.m), output)
EXPERIMENTS = {
    "step_steer": ("RLT", "Unlimited", 5.0, step_steer, {"Calpha": 280000.0, "sigmaY": 0.75},
                   ["Calpha", "sigmaY"], 40.0, "Fy"),
    "swept_sine": ("DDT", "Unlimited", 6.0, swept_sine,
                   {"Calpha": 300000.0, "sigmaY": 0.8, "dampingY": 6000.0},
                   ["Calpha", "sigmaY", "dampingY"], 40.0, "Fy"),
    "standstill_snake": ("DDT", "Coulomb", 10.0, standstill_snake,
                         {"stiffnessPsi": 45000.0, "dampingPsi": 400.0, "boreRadius": 0.08},
                         ["stiffnessPsi", "dampingPsi", "boreRadius"], 40.0, "Mz"),
    "friction_plateau": ("RLT", "Coulomb", 3.0, friction_plateau, {"muY": 0.7, "Calpha": 330000.0},
                         ["muY", "Calpha"], 60.0, "Fy"),
}


def synthesise(model, law, duration, inputs_of, truth, output, fmu=FMU):
    """The run of `fmu` (FMI 2.0 or 3.0; row k: inputs set, output read, then a step of H
    with the inputs held), noise-free."""
    import shutil
    from fmpy import extract, read_model_description

    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipdir = extract(str(fmu))
    try:
        with Slave(md, unzipdir, "synthesis", fmu) as slave:
            slave.set_selector([vr["tireModel"], vr["friction"]], [MODELS[model], LAWS[law]])
            slave.set_real([vr[n] for n in truth], list(truth.values()))
            slave.initialize(start_time=0.0)
            t = np.arange(0.0, duration + H / 2, H)
            series = inputs_of(t)
            y = np.empty_like(t)
            for k, tk in enumerate(t):
                slave.set_real([vr[n] for n in series], [float(series[n][k]) for n in series])
                y[k] = slave.get_real([vr[output]])[0]
                if k + 1 < len(t):
                    slave.do_step(tk, H)
    finally:
        shutil.rmtree(unzipdir, ignore_errors=True)
    return t, series, y


def write_csv(path, t, series, output, y):
    names = ["time"] + list(series) + [output]
    columns = [t] + [series[n] for n in series] + [y]
    np.savetxt(path, np.column_stack(columns), delimiter=",", header=",".join(names), comments="")


def fit(csv, model, law, free, out, tool=REPO / "scripts" / "fit"):
    """Runs the fitting command; returns its fit.json."""
    command = [str(tool), str(csv), "--model", model, "--friction", law, "--free", ",".join(free),
               "--out", str(out)]
    subprocess.run(command, check=True, capture_output=True, text=True)
    return json.loads((Path(out) / "fit.json").read_text())


def run(name, out, rng, tool=REPO / "scripts" / "fit", fmu=FMU):
    model, law, duration, inputs_of, truth, free, noise, output = EXPERIMENTS[name]
    t, series, y = synthesise(model, law, duration, inputs_of, truth, output, fmu)
    measured = y + rng.normal(0.0, noise, size=y.shape)
    directory = Path(out) / name
    directory.mkdir(parents=True, exist_ok=True)
    write_csv(directory / "data.csv", t, series, output, measured)
    return truth, fit(directory / "data.csv", model, law, free, directory, tool)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "out" / "fit"))
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--fmu", type=Path, default=FMU,
                        help=f"the FMU that makes the data: FMI 2.0 (default: {FMU}) or FMI 3.0")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    print(f"{'experiment':<18} {'parameter':<14} {'truth':>12} {'estimate':>12}   95 % interval")
    for name in EXPERIMENTS:
        truth, result = run(name, args.out, rng, fmu=args.fmu)
        for parameter, estimate in result["estimates"].items():
            low, high = estimate["interval"]
            inside = "in" if low <= truth[parameter] <= high else "OUT"
            print(f"{name:<18} {parameter:<14} {truth[parameter]:>12.6g} {estimate['value']:>12.6g}   "
                  f"[{low:.6g}, {high:.6g}] {inside}")
        print(f"{'':<18} {result['simulations']} simulations in {1e3 * result['seconds']:.1f} ms; "
              f"{Path(args.out) / name / 'fit.png'}")


if __name__ == "__main__":
    sys.exit(main())
