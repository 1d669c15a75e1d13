#!/usr/bin/env python3
"""The snowblower on tires read from a property file.

examples/tires/snowblower_pac2002.tir is the tire of Koo & Tan's snowblower (Table 1, the
FMU's defaults) written as a PAC2002 property file; the FMU reads it through its tirFile
parameter. This script steps the steer of the snowblower's bicycle model with RLT tires at
1.6 m/s (as snowblower_rolling.py does) three times:

* "parameters": the tires set parameter by parameter (SNOWBLOWER_TIRE, as the paper has
  them: no pneumatic trail);
* "file": the tires from the property file, whose pneumatic trail QDZ1 R0 = 0.05 m turns
  part of each tire's force into a self-aligning moment: a little more understeer;
* "file, trail 0": the file again with trail set to 0 by the importer, which the file then
  leaves alone: the same run as "parameters", to rounding.

Writes out/tire_from_file.png (yaw rate per steer angle against time) and
out/tire_from_file.csv (case, time [s], r/delta [1/s]).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cosim import load_fmu, snowblower  # noqa: E402
from cosim.cli import print_table, run_example, write_csv  # noqa: E402
from snowblower_rolling import step_steer  # noqa: E402

NAME = "tire_from_file"
TIR_FILE = Path(__file__).resolve().parent / "tires" / "snowblower_pac2002.tir"
SPEED = 1.6
CASES = {
    "parameters": {},
    "file": {"tir_file": TIR_FILE},
    "file, trail 0": {"tir_file": TIR_FILE, "tire_parameters": {"trail": 0.0}},
}


def simulate(fmu_path, quick: bool = False) -> dict:
    fmu = load_fmu(fmu_path)
    h, duration = (0.02, 30.0) if quick else (0.02, 60.0)
    res = {"step": {}, "tires": {}}
    for case, options in CASES.items():
        with snowblower(fmu, "RLT", SPEED, **options) as vehicle:
            res["tires"][case] = dict(vehicle.tires["front"].parameters)
            res["step"][case] = step_steer(vehicle, h, duration)
    return res


def report(res: dict) -> None:
    base = res["step"]["parameters"][1]
    rows = []
    for case, (t, gain) in res["step"].items():
        tire = res["tires"][case]
        rows.append([case, tire["Calpha"], tire["sigmaY"], tire["trail"], gain[-1],
                     float(np.max(np.abs(gain - base)))])
    print_table(f"  RLT snowblower at {SPEED} m/s, step steer: the tires from parameters and from "
                f"{TIR_FILE.name}",
                ["tires", "Calpha (N/rad)", "sigmaY (m)", "trail (m)", "steady r/delta (1/s)",
                 "max |difference| from parameters"], rows,
                {1: "{:.0f}", 2: "{:.3f}", 3: "{:.3f}", 4: "{:.6f}", 5: "{:.3g}"})


def write(res: dict, path: Path) -> None:
    rows = [[case, float(tk), float(gk)] for case, (t, g) in res["step"].items() for tk, gk in zip(t, g)]
    write_csv(path, ["case", "time_s", "r_per_delta_per_s"], rows)


def plot(res: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.6))
    for (case, (t, g)), style in zip(res["step"].items(), ["-", "--", ":"]):
        ax.plot(t, g, style, lw=1.6, label=case)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("r / delta (1/s)")
    ax.set_title(f"snowblower, RLT tires, {SPEED} m/s: tires from parameters and from {TIR_FILE.name}",
                 fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> dict:
    return run_example(__doc__.split("\n\n")[0], NAME, simulate, report, write, plot, argv)


if __name__ == "__main__":
    main()
