"""examples/friction_laws.py in quick mode: its printed numbers and CSVs against docs/specification.md 4c.

The example runs once (module fixture, about 2 s) into a temporary folder (never docs/).
The checks recompute everything from the CSVs with this folder's independent reference
(reference.cornering_stiffness_at, friction_reference.limits and brush_curve), not with
the example's own columns:

* Coulomb saturates at muY(Fz) Fz to 1e-9 relative, and is Calpha(Fz) tan(alpha) below it.
* Brush follows the brush curve within 0.02 Fmax (the fit's bound is 0.01304 Fmax, at
  x = 0.2, which the sweep includes), and is exactly linear below 0.2 Fmax.
* The standstill loop (RLT, vx = 0): Coulomb's reversal takes 2 Fmax/C_y of travel to
  1e-6 relative, the force never exceeds Fmax, and Unlimited is the line -C_y y.

And scripts/demo.py (the only test of the demo, about 3.5 s): its steer ramp and standstill
push saturate at Fmax with Brush, far below what the linear tire gives, and its chirp
sweeps stay below 0.2 Fmax, where Brush is exactly linear.

The example and the demo run on either FMU (ids fmi2, fmi3) with the same checks: the
example holds its inputs over each step, which FMI 3.0 does too; the demo's FMI 3.0 run
holds each step's input at the ramp's mean and must say so.

The FMI 2.0 FMU is $TIRELAG_FMU if set, else the conftest fixture's target/fmu/TireLag.fmu;
the FMI 3.0 one is target/fmu/fmi3/TireLag.fmu.
"""

from __future__ import annotations

import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import friction_reference as fr
import reference as ref

PROJECT = Path(__file__).resolve().parents[2]
EXAMPLES = PROJECT / "examples"
FMU3 = PROJECT / "target" / "fmu" / "fmi3" / "TireLag.fmu"
sys.path.insert(0, str(EXAMPLES))

import friction_laws  # noqa: E402
from cosim.cli import read_csv  # noqa: E402




@pytest.fixture(scope="module")
def run(either_fmu, tmp_path_factory):
    """The quick run: (result, printed text, output folder, docs/ PNG mtimes before)."""
    out_dir = tmp_path_factory.mktemp("friction_examples_out")
    docs = [PROJECT / "docs" / f"{n}.png" for n in (friction_laws.NAME, friction_laws.LOOP_NAME)]
    before = {p: p.stat().st_mtime_ns if p.exists() else None for p in docs}

    import contextlib
    import io

    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        res = friction_laws.main(["--quick", "--fmu", either_fmu, "--out-dir", str(out_dir)])
    after = {p: p.stat().st_mtime_ns if p.exists() else None for p in docs}
    assert after == before, "the quick run without --docs must not touch docs/"
    return res, text.getvalue(), out_dir


@pytest.fixture(scope="module")
def params(example_fmu):
    p = fr.parameters()
    start = friction_laws.load_fmu(example_fmu).start_values
    for k, v in p.items():
        if k in start:
            assert start[k] == pytest.approx(v, rel=1e-15), k
    return p


def floats(rows, *names):
    return [np.array([float(r[n]) for r in rows]) for n in names]


def printed_number(text, pattern):
    m = re.search(pattern, text)
    assert m, f"not printed: {pattern!r}\n{text}"
    return [float(g) for g in m.groups()]


def test_outputs_are_written(run):
    res, _, out_dir = run
    for name in ("friction_laws.png", "friction_laws.csv", "friction_standstill_loop.png",
                 "friction_standstill_loop.csv"):
        path = out_dir / name
        assert path.is_file() and path.stat().st_size > 500, f"{path} missing or empty"
    rows = read_csv(out_dir / "friction_laws.csv")
    assert {(r["law"], float(r["Fz_over_Fz0"])) for r in rows} == {
        ("Unlimited", 1.0), ("Coulomb", 0.5), ("Coulomb", 1.0), ("Coulomb", 1.5),
        ("Brush", 0.5), ("Brush", 1.0), ("Brush", 1.5)}
    # every point was run to steady state
    change, Fmax = floats(rows, "last_step_change_N", "Fmax_N")
    assert np.all(change <= 1e-12 * Fmax * (1 + 1e-9))


def steady_rows(out_dir, law):
    return [r for r in read_csv(out_dir / "friction_laws.csv") if r["law"] == law]


def reference_curves(params, rows):
    """x, Fmax and the linear force Calpha(Fz) tan(alpha) of each row, from the reference."""
    Fz, alpha, Fy = floats(rows, "Fz_N", "alpha_rad", "Fy_N")
    Calpha = np.array([ref.cornering_stiffness_at(params, f) for f in Fz])
    Fmax = np.array([fr.limits(params, f)["y"] for f in Fz])
    linear = Calpha * np.tan(alpha)
    return Fy, linear / Fmax, Fmax, linear


def test_coulomb_plateau_is_mu_fz(run, params):
    _, text, out_dir = run
    Fy, x, Fmax, linear = reference_curves(params, steady_rows(out_dir, "Coulomb"))
    sat = x >= 1.0 + 1e-9
    assert sat.sum() >= 10
    assert np.max(np.abs(Fy[sat] / Fmax[sat] - 1.0)) <= 1e-9
    below = (x > 0) & (x <= 1.0 - 1e-9)
    assert np.max(np.abs(Fy[below] / linear[below] - 1.0)) <= 1e-9
    # the printed plateau at Fz0: mu Fz = 0.8 x 50 kN
    plateau, mu, Fz = printed_number(text, r"Coulomb plateau = mu Fz: ([\d.]+) N = ([\d.]+) x ([\d.]+) N")
    assert mu * Fz == pytest.approx(fr.limits(params, params["Fz0"])["y"], rel=1e-15)
    assert plateau == pytest.approx(mu * Fz, rel=1e-9)


def test_brush_follows_the_brush_curve(run, params):
    _, text, out_dir = run
    rows = steady_rows(out_dir, "Brush")
    Fy, x, Fmax, linear = reference_curves(params, rows)
    deviation = np.abs(Fy / Fmax - fr.brush_curve(x))
    assert deviation.max() <= 0.02
    # the sweep includes x = 0.2, where the fit's error peaks (0.2 - b(0.2) = 0.01304)
    assert deviation.max() == pytest.approx(0.2 - float(fr.brush_curve(0.2)), rel=1e-6)
    (printed,) = printed_number(text, r"Brush max deviation from the brush curve over the sweep: ([\d.]+) Fmax")
    assert printed == pytest.approx(deviation.max(), abs=1e-5)
    # exactly linear up to 0.2 Fmax, full slide beyond the last breakpoint
    lin = (x > 0) & (x <= 0.2 + 1e-12)
    assert lin.sum() >= 6
    assert np.max(np.abs(Fy[lin] / linear[lin] - 1.0)) <= 1e-9
    x4 = max(phi / w for w, phi in fr.BRUSH_BRANCHES)
    slide = x >= x4 + 1e-9
    assert np.max(np.abs(Fy[slide] / Fmax[slide] - 1.0)) <= 1e-9
    # and it is the four-branch curve of docs/specification.md 4c, point by point
    assert np.max(np.abs(Fy / Fmax - fr.steady_force_fraction(x, "Brush"))) <= 1e-9


def test_unlimited_is_linear(run, params):
    _, _, out_dir = run
    Fy, x, _, linear = reference_curves(params, steady_rows(out_dir, "Unlimited"))
    assert x.max() > 2.5          # far beyond the limit, still linear
    nz = x > 0
    assert np.max(np.abs(Fy[nz] / linear[nz] - 1.0)) <= 1e-9


def loop_run(out_dir, law):
    rows = [r for r in read_csv(out_dir / "friction_standstill_loop.csv") if r["law"] == law]
    return floats(rows, "time_s", "vy_m_per_s", "y_m", "Fy_N")


def test_standstill_loop_reversal_takes_2_fmax_over_c_y(run, params):
    _, text, out_dir = run
    Fmax = fr.limits(params, params["Fz0"])["y"]
    C_y = params["Calpha"] / params["sigmaY"]
    exact = 2.0 * Fmax / C_y
    t, vy, y, Fy = loop_run(out_dir, "Coulomb")
    assert np.all(np.diff(t) > 0)
    assert np.allclose(np.diff(y), vy[:-1] * np.diff(t), rtol=1e-12, atol=1e-15)  # y = integral of vy
    assert np.max(np.abs(Fy)) <= Fmax * (1.0 + 1e-12)
    reversals = np.flatnonzero(np.sign(vy[1:]) != np.sign(vy[:-1])) + 1
    assert len(reversals) == 2
    for i in reversals:
        # the force starts at one limit and swings elastically (slope C_y) to the other
        assert abs(Fy[i]) == pytest.approx(Fmax, rel=1e-9)
        target = -np.sign(vy[i]) * Fmax
        j = i + np.flatnonzero(target * Fy[i:] >= Fmax ** 2 * (1.0 - 1e-9))[0]
        stick = slice(i, j)
        slope = np.polyfit(y[stick], Fy[stick], 1)[0]
        assert -slope == pytest.approx(C_y, rel=1e-9)
        # travel from the reversal to where the elastic line meets the opposite limit
        travel = abs((target - Fy[i]) / slope)
        assert travel == pytest.approx(exact, rel=1e-6)
        # and the sampled force is on the plateau after exactly that travel
        assert abs(y[j] - y[i]) == pytest.approx(exact, rel=1e-6)
    printed = printed_number(
        text, r"Coulomb: reversal travel ([\d.]+) mm, ([\d.]+) mm vs exact 2 Fmax/C_y = ([\d.]+) mm")
    assert printed[2] == pytest.approx(1e3 * exact, rel=1e-8)
    for value in printed[:2]:
        assert value == pytest.approx(1e3 * exact, rel=1e-6)
    for value in run[0]["loop_numbers"]["Coulomb"]["travel"]:
        assert value == pytest.approx(exact, rel=1e-6)


def test_standstill_loop_brush_and_unlimited(run, params):
    res, _, out_dir = run
    Fmax = fr.limits(params, params["Fz0"])["y"]
    C_y = params["Calpha"] / params["sigmaY"]
    _, _, y, Fy = loop_run(out_dir, "Unlimited")
    moving = np.abs(y) > 0
    assert np.max(np.abs(-Fy[moving] / (C_y * y[moving]) - 1.0)) <= 1e-9
    _, _, y, Fy = loop_run(out_dir, "Brush")
    assert np.max(np.abs(Fy)) <= Fmax * (1.0 + 1e-12)
    assert np.max(np.abs(Fy)) == pytest.approx(Fmax, rel=1e-9)   # the push reaches the full limit
    # Brush's last branch sticks again until the swing reaches 2 x_4 Fmax/C_y
    x4 = max(phi / w for w, phi in fr.BRUSH_BRANCHES)
    for travel in res["loop_numbers"]["Brush"]["travel"]:
        assert travel == pytest.approx(2.0 * x4 * Fmax / C_y, rel=1e-6)
    assert math.isclose(friction_laws.BRUSH_BREAKPOINTS[-1], x4, rel_tol=1e-12)


# --------------------------------------------------------------------------- the demo

def test_demo_shows_the_friction_limit(either_fmu, params, tmp_path):
    """scripts/demo.py (what ./scripts/demo runs after building), on either FMU: the chirps
    stay linear, the steer ramp and the standstill push saturate at Fmax with Brush, and the
    linear tire (Unlimited) goes far beyond; it prints the line about the limit, and which
    FMI version it ran and how it gave the inputs."""
    import contextlib
    import io

    sys.path.insert(0, str(PROJECT / "scripts"))
    import demo

    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        demo.main([either_fmu, "--out-dir", str(tmp_path)])
    text = text.getvalue()
    held = Path(either_fmu) == FMU3
    expected = ("FMI 3.0; inputs held at each step's mean" if held
                else "FMI 2.0; inputs ramped exactly (fmi2SetRealInputDerivatives)")
    assert f"FMU: {either_fmu} ({expected}" in text, text
    for name in ("demo.csv", "demo.png"):
        assert (tmp_path / name).stat().st_size > 500
    Fmax = fr.limits(params, params["Fz0"])["y"]
    (printed,) = printed_number(text, r"Fy saturates at muY\(Fz\) Fz = ([\d.]+) kN with Brush")
    assert printed == pytest.approx(Fmax / 1e3, abs=0.05)

    peak = {}
    for r in read_csv(tmp_path / "demo.csv"):
        key = (r["scenario"], r["model"], r["friction"], float(r["vx"]))
        peak[key] = max(peak.get(key, 0.0), abs(float(r["Fy"])))
    assert len(peak) == 2 * 3 * 4 + 2 * 2
    for (scenario, model, law, vx), F in peak.items():
        if scenario in ("lateral", "steer"):
            assert law == "Brush" and F < 0.2 * Fmax, (scenario, model, vx, F)   # exactly linear there
        elif law == "Brush":
            assert model == "DDT"
            assert F == pytest.approx(Fmax, rel=1e-9), (scenario, F)   # on the limit, never beyond
        else:
            assert law == "Unlimited" and F > 2.5 * Fmax, (scenario, F)
