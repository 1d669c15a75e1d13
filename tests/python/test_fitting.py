"""Fitting parameters to measurements (SPEC 10), on the synthetic experiments of
examples/fit_synthetic.py: data made by the FMU from known parameters, with Gaussian noise.

a. Coverage: over DRAWS noise draws of each experiment, the stated 95 % interval of every
   fitted parameter holds the value that made the data in at least MIN_COVERAGE of them
   (at 30 draws a true 95 % interval falls below 80 % with probability 2e-3), and the
   errors over the standard errors scatter like a unit normal (their rms within 0.6-1.5).
   RLT's Calpha and sigmaY from a step steer; DDT's Calpha, sigmaY and dampingY from a
   swept sine; DDT's yaw set (stiffnessPsi, dampingPsi and the plateau through boreRadius)
   from the standstill snake; the friction plateau muY with Calpha.
b. The command writes the fit as JSON, as an SSP parameter set fmpy reads back, as a CSV of
   measured and fitted outputs, and as a PNG; the example script runs and reports.
c. Data it cannot use (no time column, no output, a bad row) stop it with the reason.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "examples"))
import fit_synthetic as fs  # noqa: E402

DRAWS = 30
MIN_COVERAGE = 0.8
FIT = REPO / "scripts" / "fit"


@pytest.fixture(scope="module")
def fit_command():
    """The command itself (scripts/fit builds it and then plots; the draws skip the plot)."""
    subprocess.run([str(REPO / "scripts" / "setup")], check=True, capture_output=True)
    env = "source scripts/portable-env && zigbuild build --release --quiet --bin tirelag-fit " \
          "--target \"$TIRELAG_ZIG_TARGET\""
    subprocess.run(["bash", "-c", env], cwd=REPO, check=True, capture_output=True)
    return REPO / "target" / "x86_64-unknown-linux-gnu" / "release" / "tirelag-fit"


@pytest.mark.parametrize("name", list(fs.EXPERIMENTS))
def test_intervals_cover_the_parameters_that_made_the_data(fit_command, name, tmp_path):
    model, law, duration, inputs_of, truth, free, noise, output = fs.EXPERIMENTS[name]
    t, series, y = fs.synthesise(model, law, duration, inputs_of, truth, output)
    rng = np.random.default_rng(fs.__name__.__len__() + len(name))
    covered = {p: 0 for p in free}
    z = {p: [] for p in free}
    simulations = []
    for draw in range(DRAWS):
        directory = tmp_path / str(draw)
        directory.mkdir()
        fs.write_csv(directory / "data.csv", t, series, output, y + rng.normal(0.0, noise, y.shape))
        subprocess.run([str(fit_command), str(directory / "data.csv"), "--model", model,
                        "--friction", law, "--free", ",".join(free), "--out", str(directory)],
                       check=True, capture_output=True, text=True)
        result = json.loads((directory / "fit.json").read_text())
        simulations.append(result["simulations"])
        for p in free:
            estimate = result["estimates"][p]
            low, high = estimate["interval"]
            covered[p] += low <= truth[p] <= high
            z[p].append((estimate["value"] - truth[p]) / estimate["standard_error"])
    report = {p: (covered[p] / DRAWS, float(np.sqrt(np.mean(np.square(z[p]))))) for p in free}
    print(f"{name}: coverage and rms of the standardised errors {report}; "
          f"{np.mean(simulations):.0f} simulations a fit")
    for p, (coverage, rms) in report.items():
        assert coverage >= MIN_COVERAGE, (name, p, report)
        assert 0.6 <= rms <= 1.5, (name, p, report)


def test_the_command_writes_every_result_and_the_example_reports(tmp_path):
    from fmpy.ssp.ssd import read_ssv

    truth, result = fs.run("step_steer", tmp_path, np.random.default_rng(5), tool=FIT)
    directory = tmp_path / "step_steer"
    for name in ("fit.json", "fit.ssv", "fit.csv", "fit.png"):
        assert (directory / name).stat().st_size > 0, name
    written = {p.name: p for p in read_ssv(str(directory / "fit.ssv")).parameters}
    for name, estimate in result["estimates"].items():
        assert float(written[name].value) == estimate["value"]
    assert int(written["tireModel"].value) == 1 and int(written["friction"].value) == 1
    table = np.genfromtxt(directory / "fit.csv", delimiter=",", names=True)
    assert set(table.dtype.names) == {"time", "Fy_measured", "Fy_fitted"}
    assert np.sqrt(np.mean((table["Fy_measured"] - table["Fy_fitted"]) ** 2)) == pytest.approx(
        result["residual_rms"]["Fy"], rel=1e-9)
    run = subprocess.run([sys.executable, str(REPO / "examples" / "fit_synthetic.py"), "--out",
                          str(tmp_path / "example")], capture_output=True, text=True, check=True)
    rows = [line for line in run.stdout.splitlines() if line.rstrip().endswith((" in", " OUT"))]
    assert len(rows) == sum(len(e[5]) for e in fs.EXPERIMENTS.values()), run.stdout


@pytest.mark.parametrize("text,reason", [
    ("vy,Fy\n0,1\n1,2\n", "no 'time' column"),
    ("time,vy\n0,1\n1,2\n", "none of the outputs"),
    ("time,vy,Fy\n0,1,2\n0.1,x,3\n", "line 3"),
])
def test_data_it_cannot_use_stop_it_with_the_reason(fit_command, tmp_path, text, reason):
    data = tmp_path / "data.csv"
    data.write_text(text)
    run = subprocess.run([str(fit_command), str(data), "--free", "Calpha", "--out", str(tmp_path)],
                         capture_output=True, text=True)
    assert run.returncode == 2 and reason in run.stderr, run.stderr
