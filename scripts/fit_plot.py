"""Plots a fit's measured and fitted outputs (DIR/fit.csv) with its estimates
(DIR/fit.json) into DIR/fit.png:   python scripts/fit_plot.py DIR"""

import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(directory):
    directory = Path(directory)
    data = np.genfromtxt(directory / "fit.csv", delimiter=",", names=True)
    fit = json.loads((directory / "fit.json").read_text())
    outputs = [n[: -len("_measured")] for n in data.dtype.names if n.endswith("_measured")]
    figure, axes = plt.subplots(len(outputs), 1, figsize=(8, 2.8 * len(outputs)), sharex=True,
                                squeeze=False)
    for axis, name in zip(axes[:, 0], outputs):
        axis.plot(data["time"], data[f"{name}_measured"], ".", ms=2, color="0.55", label="measured")
        axis.plot(data["time"], data[f"{name}_fitted"], "-", lw=1.4, color="C3", label="fitted")
        rms = fit["residual_rms"][name]
        axis.set_ylabel(name)
        axis.set_title(f"{name}: residual rms {rms:.4g}", fontsize=9, loc="left")
        axis.grid(alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize=8)
    axes[-1, 0].set_xlabel("time (s)")
    estimates = ", ".join(
        f"{name} = {e['value']:.5g} [{e['interval'][0]:.4g}, {e['interval'][1]:.4g}]"
        for name, e in fit["estimates"].items())
    figure.suptitle(f"{fit['model']} ({fit['friction']}): {estimates}", fontsize=9)
    figure.tight_layout()
    figure.savefig(directory / "fit.png", dpi=110)
    print(f"wrote {directory / 'fit.png'}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "fit-out")
