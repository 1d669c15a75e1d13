"""Fitting parameters to measurements (docs/specification.md 10), on the synthetic experiments of
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
c. Data it cannot use (no time column, no output, a bad row, a column it does not know)
   stop it with the reason.
d. `--help` prints the usage and fits and plots nothing; the plot copes with intervals
   that are unbounded (null, infinite, NaN or missing in fit.json), keeps its title inside
   the figure and labels its axes with their units.
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
sys.path.insert(0, str(REPO / "scripts"))
import fit_plot  # noqa: E402
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


def test_an_unknown_column_stops_the_fit_naming_it_and_the_accepted_ones(tmp_path):
    # A misspelt vy was read as no vy: every interval came out [-inf, inf].
    data = tmp_path / "data.csv"
    data.write_text("time,vx,vyy,Fy\n0,10,0,0\n0.01,10,-0.2,50\n0.02,10,-0.2,90\n")
    run = subprocess.run([str(FIT), str(data), "--free", "Calpha", "--out", str(tmp_path / "out")],
                         capture_output=True, text=True)
    assert run.returncode == 2, run.stderr
    assert "'vyy'" in run.stderr, run.stderr
    assert "time, an input (vx, vy, steerRate, vsx, Fz) or a measured output (Fx, Fy, Mz)" \
        in run.stderr, run.stderr
    assert "Traceback" not in run.stderr and not (tmp_path / "out").exists(), run.stderr


@pytest.mark.parametrize("args", [["--help"], ["-h"], ["data.csv", "--free", "Calpha", "--help"]])
def test_help_prints_every_option_and_fits_and_plots_nothing(tmp_path, args):
    run = subprocess.run([str(FIT), *args], cwd=tmp_path, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    for text in ["usage: tirelag-fit DATA.csv --free", "--model", "--friction", "--tir", "--set",
                 "--bounds", "--out DIR", "-h, --help", "stiffnessPsi (N.m/rad)", "DIR/fit.json",
                 "DIR/fit.ssv", "DIR/fit.csv", "DIR/fit.png"]:
        assert text in run.stdout, (text, run.stdout)
    # Neither the fit nor the plot ran: nothing written, no "wrote" line.
    assert list(tmp_path.iterdir()) == [] and "wrote" not in run.stdout, run.stdout


def write_fit_by_hand(directory, estimates, outputs=("Fy",)):
    """A fit's out directory as the command writes it, with `estimates` as raw JSON text."""
    directory.mkdir(parents=True, exist_ok=True)
    t = np.linspace(0.0, 2.0, 201)
    columns = {"time": t}
    for k, name in enumerate(outputs):
        fitted = 1000.0 * (k + 1) * np.sin(2 * np.pi * t)
        columns[f"{name}_measured"] = fitted + np.random.default_rng(k).normal(0.0, 20.0, t.shape)
        columns[f"{name}_fitted"] = fitted
    np.savetxt(directory / "fit.csv", np.column_stack(list(columns.values())), delimiter=",",
               header=",".join(columns), comments="")
    rms = ", ".join(f'"{name}": 20.0' for name in outputs)
    (directory / "fit.json").write_text(
        f'{{"model": "DDT", "friction": "Coulomb", "estimates": {{{estimates}}}, '
        f'"residual_rms": {{{rms}}}, "iterations": 3, "simulations": 20, "seconds": 0.01}}\n')


@pytest.mark.parametrize("interval", ['"interval": [null, null]', '"interval": [-Infinity, Infinity]',
                                      '"interval": [NaN, 420.0]', '"interval": null', ''])
def test_the_plot_draws_an_unbounded_interval_as_unbounded(tmp_path, interval):
    fields = ['"value": 400.0', '"standard_error": null', interval, '"unit": "N.m.s/rad"']
    unknown = "{" + ", ".join(f for f in fields if f) + "}"
    known = '{"value": 45000.0, "standard_error": 90.0, "interval": [44823.6, 45176.4], ' \
            '"unit": "N.m/rad"}'
    write_fit_by_hand(tmp_path, f'"dampingPsi": {unknown}, "stiffnessPsi": {known}')
    run = subprocess.run([sys.executable, str(REPO / "scripts" / "fit_plot.py"), str(tmp_path)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "fit.png").stat().st_size > 0
    title = fit_plot.title_lines(json.loads((tmp_path / "fit.json").read_text()))
    assert "dampingPsi = 400 N.m.s/rad, interval unbounded" in title, title
    assert "stiffnessPsi = 45000 N.m/rad, 95 % in [44824, 45176]" in title, title


def test_a_parameter_the_data_do_not_determine_is_fitted_and_plotted_unbounded(tmp_path):
    # sigmaX does not act on Fy without longitudinal slip: the sensitivities are singular.
    model, law, duration, inputs_of, truth, free, noise, output = fs.EXPERIMENTS["step_steer"]
    t, series, y = fs.synthesise(model, law, duration, inputs_of, truth, output)
    fs.write_csv(tmp_path / "data.csv", t, series, output,
                 y + np.random.default_rng(3).normal(0.0, noise, y.shape))
    run = subprocess.run([str(FIT), str(tmp_path / "data.csv"), "--model", model, "--free",
                          "Calpha,sigmaX", "--out", str(tmp_path)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    result = json.loads((tmp_path / "fit.json").read_text())
    assert result["estimates"]["sigmaX"]["interval"] == [None, None], result
    assert result["estimates"]["sigmaX"]["unit"] == "m", result
    assert (tmp_path / "fit.png").stat().st_size > 0
    assert "sigmaX = 0.5 m, interval unbounded" in fit_plot.title_lines(result)


def test_the_plot_title_stays_inside_the_figure_and_the_axes_have_units(tmp_path):
    names = ["stiffnessPsi", "dampingPsi", "boreRadius", "carcassDampingY", "muLoadSensitivity",
             "calphaLoadPeak"]
    estimates = ", ".join(
        f'"{n}": {{"value": {1234.56789 * (k + 1)}, "standard_error": 1.0, '
        f'"interval": [{1234.56789 * (k + 1) - 1.96}, {1234.56789 * (k + 1) + 1.96}], '
        f'"unit": "N.m.s/rad"}}' for k, n in enumerate(names))
    write_fit_by_hand(tmp_path, estimates, outputs=("Fx", "Fy", "Mz"))
    figure = fit_plot.draw(json.loads((tmp_path / "fit.json").read_text()),
                           np.genfromtxt(tmp_path / "fit.csv", delimiter=",", names=True))
    figure.canvas.draw()
    width, height = figure.bbox.width, figure.bbox.height
    for text in figure.texts:
        box = text.get_window_extent()
        assert 0 <= box.x0 and box.x1 <= width and 0 <= box.y0 and box.y1 <= height, \
            (text.get_text(), box, width, height)
    labels = [axis.get_ylabel() for axis in figure.axes]
    assert labels == ["Fx, longitudinal force (N)", "Fy, lateral force (N)",
                      "Mz, moment about z (N.m)"], labels
    assert figure.axes[-1].get_xlabel() == "time (s)"
    assert [axis.get_title(loc="left") for axis in figure.axes] == [
        "Fx: residual rms 20 N", "Fy: residual rms 20 N", "Mz: residual rms 20 N.m"]
    figure.savefig(tmp_path / "fit.png", dpi=110)
