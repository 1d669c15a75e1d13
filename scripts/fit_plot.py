"""Plots a fit's measured and fitted outputs (DIR/fit.csv) with its estimates
(DIR/fit.json) into DIR/fit.png:   python scripts/fit_plot.py DIR

An estimate whose interval is missing, null, infinite or NaN (a parameter the data do not
determine) is drawn as "interval unbounded" instead of failing."""

import json
import math
import sys
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

# The outputs a fit compares (src/fitting/data.rs): quantity and unit.
OUTPUTS = {"Fx": ("longitudinal force", "N"), "Fy": ("lateral force", "N"),
           "Mz": ("moment about z", "N.m")}
TITLE_WIDTH = 95   # characters a title line may hold at fontsize 9 across the 8 in figure


def finite(value):
    """The value as a float if it is a finite number, else None (null, inf, NaN, text)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if math.isfinite(value) else None


def estimate_text(name, estimate):
    """One estimate as 'name = value unit, 95 % in [low, high]', or why it has none."""
    value = finite(estimate.get("value"))
    unit = estimate.get("unit") or ""
    unit = "" if unit == "1" else unit   # a plain number: no unit to write
    if value is None:
        return f"{name}: no finite value"
    interval = estimate.get("interval")
    low, high = (interval if isinstance(interval, (list, tuple)) and len(interval) == 2
                 else (None, None))
    low, high = finite(low), finite(high)
    text = f"{name} = {value:.6g} {unit}".rstrip()
    if low is None or high is None:
        return f"{text}, interval unbounded"
    return f"{text}, 95 % in [{low:.5g}, {high:.5g}]"


def title_lines(fit):
    """The title, a line an estimate, each wrapped to the figure's width."""
    estimates = fit.get("estimates") or {}
    texts = [estimate_text(name, e) for name, e in estimates.items()]
    lines = [f"{fit.get('model', '?')} model, {fit.get('friction', '?')} friction: "
             "fitted values and 95 % intervals"]
    for text in texts:
        lines += textwrap.wrap(text, TITLE_WIDTH, subsequent_indent="    ")
    # One free parameter without effect on the data leaves every interval unbounded.
    if any(t.endswith("unbounded") for t in texts):
        lines.append("(unbounded: the data do not determine the free parameters together)")
    return lines


def draw(fit, data):
    """The figure: an axis an output, measured dots against the fitted line."""
    outputs = [n[: -len("_measured")] for n in data.dtype.names if n.endswith("_measured")]
    title = title_lines(fit)
    figure, axes = plt.subplots(len(outputs), 1, sharex=True, squeeze=False, layout="constrained",
                                figsize=(8, 2.8 * len(outputs) + 0.2 * len(title)))
    for axis, name in zip(axes[:, 0], outputs):
        quantity, unit = OUTPUTS.get(name, (name, "1"))
        axis.plot(data["time"], data[f"{name}_measured"], ".", ms=2, color="0.55", label="measured")
        axis.plot(data["time"], data[f"{name}_fitted"], "-", lw=1.4, color="C3", label="fitted")
        rms = finite((fit.get("residual_rms") or {}).get(name))
        rms_text = "not finite" if rms is None else f"{rms:.4g} {unit}"
        axis.set_ylabel(f"{name}, {quantity} ({unit})")
        axis.set_title(f"{name}: residual rms {rms_text}", fontsize=9, loc="left")
        axis.grid(alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize=8)
    axes[-1, 0].set_xlabel("time (s)")
    figure.suptitle("\n".join(title), fontsize=9)
    return figure


def main(directory):
    directory = Path(directory)
    data = np.genfromtxt(directory / "fit.csv", delimiter=",", names=True)
    fit = json.loads((directory / "fit.json").read_text())
    figure = draw(fit, data)
    figure.savefig(directory / "fit.png", dpi=110)
    plt.close(figure)
    print(f"wrote {directory / 'fit.png'}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "fit-out")
