"""Tire data in: `tirFile` (docs/specification.md 10 and the file lines of 8).

For a PAC2002 file (examples/tires/snowblower_pac2002.tir) and an MF 6.1 file
(tests/data/mf61_passenger.tir, with scaling factors other than 1 and PKY4 != 2):
a. every value the FMU maps equals the formula of docs/specification.md 10 computed here from the file's
   keys by a parser of this test's own (1e-12 relative; the load peak fitted for PKY4 != 2,
   by a least-squares fit of this test's own on 0.25-2 Fz0, to 1e-6);
b. the FMU with the file set steers to Calpha alpha at a small slip and saturates at
   muY(Fz) Fz at a large one (Coulomb, rolling, 1e-9 of the force);
c. a parameter the importer set keeps its value; the others take the file's;
d. the path is found absolute, as a file: URI and relative: first in the FMU's resources
   folder, if it holds the file, then in the current working directory (FMI 2.0 and 3.0);
   a relative path in neither is an fmi2Error naming every path tried;
e. a file that cannot be used (missing, not a tire file, a bad line, a missing key, a value
   out of range) fails fmi2ExitInitializationMode with fmi2Error naming the file and the
   line or key and value, and changes nothing: the instance can be reset and run;
f. the mapping command prints each value with its source and writes an SSP parameter set
   that fmpy reads back with the same values.
"""

from __future__ import annotations

import ctypes
import math
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import fmi4_common as fc
from conftest import REPO

PAC2002 = REPO / "examples" / "tires" / "snowblower_pac2002.tir"
MF61 = REPO / "tests" / "data" / "mf61_passenger.tir"
TIR_VR = 130
VR = {**fc.ALL_PARAMETER_VR}


def read_keys(path):
    """KEY -> number, for every `KEY = number` line (keys upper-cased; comments, tables and
    strings left out): the test's own reading of a property file."""
    keys = {}
    for line in Path(path).read_text(encoding="latin-1").splitlines():
        line = line.split("$", 1)[0].strip()
        if "=" not in line or line.startswith(("!", "{", "[")):
            continue
        key, value = (part.strip() for part in line.split("=", 1))
        try:
            keys[key.upper()] = float(value)
        except ValueError:
            pass
    return keys


def fitted_peak(pky2, pky4):
    """c2 minimising sum (x (1 + 1/c2^2)/(1 + x^2/c2^2) - Kya(x)/Kya(1))^2 on x in
    [0.25, 2] (71 points), Kya(x) ~ sin(PKY4 atan(x/PKY2))."""
    from scipy.optimize import minimize_scalar

    x = np.linspace(0.25, 2.0, 71)
    mf = np.sin(pky4 * np.arctan(x / pky2)) / np.sin(pky4 * np.arctan(1.0 / pky2))

    def error(log_c2):
        c2 = math.exp(log_c2)
        return float(np.sum((x * (1 + 1 / c2**2) / (1 + x**2 / c2**2) - mf) ** 2))

    best = minimize_scalar(error, bounds=(math.log(0.05), math.log(50.0)), method="bounded",
                           options={"xatol": 1e-12})
    return math.exp(best.x)


def expected_mapping(path):
    """The table of docs/specification.md 10, from the file's keys."""
    k = read_keys(path)
    L = lambda name: k.get(name, 1.0)  # noqa: E731  (scaling factors default to 1)
    fz0 = k["FNOMIN"] * L("LFZO")
    pky4 = k.get("PKY4", 2.0)
    calpha = abs(k["PKY1"] * fz0 * math.sin(pky4 * math.atan(1 / k["PKY2"]))) * L("LKY")
    ckappa = k["PKX1"] * fz0 * L("LKX")
    r0 = k["UNLOADED_RADIUS"]
    out = {
        "Fz0": fz0,
        "Calpha": calpha,
        "calphaLoadPeak": abs(k["PKY2"]) if pky4 == 2.0 else fitted_peak(k["PKY2"], pky4),
        "Ckappa": ckappa,
        "muX": abs(k["PDX1"]) * L("LMUX"),
        "muY": abs(k["PDY1"]) * L("LMUY"),
        "muLoadSensitivity": k["PDY2"] / k["PDY1"],
        "trail": k["QDZ1"] * r0 * L("LTR"),
    }
    if "LATERAL_STIFFNESS" in k:
        out["sigmaY"] = calpha / k["LATERAL_STIFFNESS"]
    else:
        out["sigmaY"] = k["PTY1"] * math.sin(2 * math.atan(1 / k["PTY2"])) * r0 * L("LFZO") * L("LSGAL")
    if "LONGITUDINAL_STIFFNESS" in k:
        out["sigmaX"] = ckappa / k["LONGITUDINAL_STIFFNESS"]
    else:
        out["sigmaX"] = k["PTX1"] * r0 * L("LSGKP")
    if all(name in k for name in ("FREFF", "DREFF", "BREFF", "VERTICAL_STIFFNESS")):
        rho = fz0 / k["FNOMIN"]
        out["Re"] = r0 - k["FNOMIN"] / k["VERTICAL_STIFFNESS"] * (
            k["DREFF"] * math.atan(k["BREFF"] * rho) + k["FREFF"] * rho)
    else:
        out["Re"] = r0
    return out


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    return fc.module_fmu(tmp_path_factory, "tire_data")


@pytest.fixture
def slaves(fmu):
    with fc.slave_factory(*fmu, "td") as new:
        yield new


def with_file(slave, tir, model="RLT", friction="Coulomb", params=None):
    """setupExperiment, the selectors, parameters and tirFile; then enter and exit
    initialisation. Returns the exit status."""
    slave.setupExperiment(startTime=0.0)
    slave.setInteger([fc.MODEL_VR, fc.FRICTION_VR], [fc.MODELS[model], fc.FRICTIONS[friction]])
    if params:
        slave.setReal([VR[n] for n in params], [float(v) for v in params.values()])
    slave.setString([TIR_VR], [str(tir)])
    slave.enterInitializationMode()
    status, _ = fc.status_of(slave.exitInitializationMode)
    return status


def values(slave, names):
    return dict(zip(names, slave.getReal([VR[n] for n in names])))


@pytest.mark.parametrize("path", [PAC2002, MF61], ids=["PAC2002", "MF6.1"])
def test_every_mapped_value_follows_the_formulas(slaves, path):
    expected = expected_mapping(path)
    s = slaves(init=False)
    assert with_file(s, path) == fc.FMI2_OK
    got = values(s, list(expected))
    for name, value in expected.items():
        tolerance = 1e-6 if name == "calphaLoadPeak" else 1e-12
        assert got[name] == pytest.approx(value, rel=tolerance, abs=1e-15), (name, got[name], value)
    assert s.getString([TIR_VR]) == [str(path).encode()]   # fmpy returns the bytes
    # Values the file does not hold keep their defaults.
    defaults = fc.start_values(fc.read_md())
    for name in ("dampingY", "contactMass", "boreRadius", "sigmaTread"):
        assert values(s, [name])[name] == defaults[name], name
    if path == PAC2002:
        # The example file writes the FMU's own defaults (snowblower, Koo & Tan).
        for name in expected:
            assert got[name] == pytest.approx(defaults[name], rel=1e-12), name


@pytest.mark.parametrize("path", [PAC2002, MF61], ids=["PAC2002", "MF6.1"])
def test_the_fmu_steers_and_saturates_as_the_file_says(slaves, path):
    """RLT with Coulomb at vx = 10 m/s and the nominal load: after 30 relaxation lengths
    of travel the lateral force is Calpha alpha at alpha = 1e-3 (below the limit) and
    muY Fz0 at alpha = 0.3 (the sign of docs/specification.md 2: positive alpha = -vy/vx gives positive Fy)."""
    m = expected_mapping(path)
    for alpha, force in [(1e-3, m["Calpha"] * 1e-3), (0.3, m["muY"] * m["Fz0"])]:
        s = slaves(init=False)
        assert with_file(s, path) == fc.FMI2_OK
        s.setReal([fc.INPUT_VR["vx"], fc.INPUT_VR["vy"]], [10.0, -10.0 * alpha])
        t, h = 0.0, 0.01
        for _ in range(int(30 * m["sigmaY"] / 10.0 / h) + 1):
            s.doStep(t, h)
            t += h
        fy = s.getReal([fc.OUTPUT_VR["Fy"]])[0]
        assert fy == pytest.approx(force, rel=1e-9), (alpha, fy, force)


def test_parameters_the_importer_set_keep_their_values(slaves):
    s = slaves(init=False)
    assert with_file(s, MF61, params={"Calpha": 60000.0, "muY": 1.1}) == fc.FMI2_OK
    expected = expected_mapping(MF61)
    got = values(s, ["Calpha", "muY", "Ckappa", "sigmaY"])
    assert got["Calpha"] == 60000.0 and got["muY"] == 1.1
    assert got["Ckappa"] == pytest.approx(expected["Ckappa"], rel=1e-12)
    # sigmaY is mapped from the file's Calpha (docs/specification.md 10), not the importer's.
    assert got["sigmaY"] == pytest.approx(expected["sigmaY"], rel=1e-12)


def test_the_path_may_be_a_uri_or_relative_to_the_resources(fmu, slaves):
    md, unzipdir = fmu
    resources = Path(unzipdir) / "resources"
    resources.mkdir(exist_ok=True)
    shutil.copy(MF61, resources / "front tire.tir")
    expected = expected_mapping(MF61)["Calpha"]
    for given in ["front tire.tir", MF61.as_uri(), str(MF61)]:
        s = slaves(init=False)
        assert with_file(s, given) == fc.FMI2_OK, given
        assert values(s, ["Calpha"])["Calpha"] == pytest.approx(expected, rel=1e-12), given


def logged_instance(md, unzipdir, name, resources=True):
    """An FMU2Slave with logging on (its log: `slave.log`, a LogCapture), instantiated with
    the resources folder fmpy gives, or (resources=False) with none, as an importer may."""
    from fmpy.fmi2 import FMU2Slave, fmi2CoSimulation

    log = fc.LogCapture()
    if resources:
        slave = fc.new_slave(md, unzipdir, name=name, log=log, logging_on=True)
    else:
        slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir,
                          modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        slave.callbacks = log.callbacks
        slave.component = slave.fmi2Instantiate(name.encode(), fmi2CoSimulation, md.guid.encode(), None,
                                                ctypes.byref(slave.callbacks), False, True)
        assert slave.component, "fmi2Instantiate without a resources folder returned NULL"
    slave.log = log
    return slave


def test_a_relative_path_is_looked_up_in_the_resources_then_the_working_directory(fmu, tmp_path,
                                                                                  monkeypatch):
    """From a temporary working directory: a relative tirFile the resources folder does not
    hold is read from the working directory; where both hold the name, the resources
    folder's file wins; without a resources folder the working directory still serves.
    The log names the file read."""
    md, unzipdir = fmu
    work = tmp_path / "work"
    (work / "tires").mkdir(parents=True)
    monkeypatch.chdir(work)
    here = Path(os.getcwd())                 # as the FMU sees it (symbolic links resolved)
    shutil.copy(MF61, work / "tires" / "rear.tir")
    shutil.copy(PAC2002, work / "tires" / "both.tir")
    in_resources = Path(unzipdir) / "resources" / "tires"
    in_resources.mkdir(parents=True, exist_ok=True)
    shutil.copy(MF61, in_resources / "both.tir")
    cases = [("tires/rear.tir", here / "tires" / "rear.tir", MF61, True),
             ("tires/both.tir", in_resources / "both.tir", MF61, True),
             ("tires/both.tir", here / "tires" / "both.tir", PAC2002, False),
             (os.path.join("..", "work", "tires", "rear.tir"), here / ".." / "work" / "tires" / "rear.tir",
              MF61, True)]
    assert expected_mapping(MF61)["Calpha"] != pytest.approx(expected_mapping(PAC2002)["Calpha"], rel=1e-3)
    for given, read, source, resources in cases:
        s = logged_instance(md, unzipdir, "relative", resources=resources)
        try:
            assert with_file(s, given) == fc.FMI2_OK, (given, s.log.text())
            assert values(s, ["Calpha"])["Calpha"] == pytest.approx(
                expected_mapping(source)["Calpha"], rel=1e-12), given
            assert f"tirFile {read}: " in s.log.text(), (given, s.log.text())
        finally:
            s.freeInstance()


def test_a_relative_path_found_nowhere_is_an_error_naming_every_path_tried(fmu, tmp_path, monkeypatch):
    """fmi2Error at fmi2ExitInitializationMode, with a message that names the path in the
    resources folder and the one in the working directory (or says there is no resources
    folder); nothing changes, and the instance recovers by a reset."""
    md, unzipdir = fmu
    monkeypatch.chdir(tmp_path)
    here = Path(os.getcwd())
    defaults = fc.start_values(md)
    for resources, tried in [(True, [Path(unzipdir) / "resources" / "tires" / "none.tir",
                                     here / "tires" / "none.tir"]),
                             (False, ["no resources folder", here / "tires" / "none.tir"])]:
        s = logged_instance(md, unzipdir, "nowhere", resources=resources)
        try:
            assert with_file(s, "tires/none.tir") == fc.FMI2_ERROR, s.log.text()
            errors = "\n".join(s.log.errors())
            assert "tirFile 'tires/none.tir' is a relative path" in errors, errors
            for place in tried:
                assert str(place) in errors, (place, errors)
            assert values(s, ["Calpha"])["Calpha"] == defaults["Calpha"]
            s.reset()
            fc.initialise(s, "RLT", inputs={"vx": 5.0, "vy": 0.1})
            s.doStep(0.0, 0.01)
            assert math.isfinite(s.getReal([fc.OUTPUT_VR["Fy"]])[0])
        finally:
            s.freeInstance()


def test_the_fmi3_fmu_finds_a_relative_path_in_the_working_directory(tmp_path, monkeypatch):
    """The FMI 3.0 FMU (its resources folder a native path, docs/specification.md 7c) looks up a relative
    tirFile the same way, and names both places when it is in neither."""
    import fmi3_common as f3

    md = f3.read_md3()
    unzipdir = f3.extract_fmu3(tmp_path / "fmu3")
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    shutil.copy(MF61, work / "rear.tir")
    found = f3.new_slave3(md, unzipdir, "relative3")
    missing = f3.new_slave3(md, unzipdir, "missing3")
    try:
        found.setString([f3.TIR_FILE_VR], ["rear.tir"])
        f3.initialise3(found, "RLT")
        calpha = found.getFloat64([fc.ALL_PARAMETER_VR["Calpha"]])[0]
        assert calpha == pytest.approx(expected_mapping(MF61)["Calpha"], rel=1e-12)
        missing.setString([f3.TIR_FILE_VR], ["none.tir"])
        missing.enterInitializationMode(startTime=0.0)
        status, _ = fc.status_of(missing.exitInitializationMode)
        assert status == f3.FMI3_ERROR
        errors = "\n".join(missing.log.errors())
        for place in (Path(unzipdir) / "resources" / "none.tir", Path(os.getcwd()) / "none.tir"):
            assert str(place) in errors, (place, errors)
    finally:
        f3.close3(found)
        f3.close3(missing)


def write_variant(tmp_path, replace, name="variant.tir"):
    """A copy of the MF 6.1 file with lines replaced: {old line start: new line or None}."""
    lines = MF61.read_text().splitlines()
    out = []
    for line in lines:
        for start, new in replace.items():
            if line.startswith(start):
                line = new
                break
        if line is not None:
            out.append(line)
    path = tmp_path / name
    path.write_text("\n".join(out) + "\n")
    return path


def bad_files(tmp_path):
    """(path, words the error must name) for files that cannot be used (the last one by
    the contact-mass model only: its tread must stay shorter than the mapped lengths)."""
    fifo = tmp_path / "pipe.tir"
    os.mkfifo(fifo)
    return [
        (tmp_path / "missing.tir", ["missing.tir", "cannot be read"]),
        # A device or a pipe is refused at once, not read forever or waited on.
        (Path("/dev/zero"), ["/dev/zero", "not a regular file"]),
        (fifo, ["pipe.tir", "not a regular file"]),
        (write_variant(tmp_path, {"FILE_TYPE": "FILE_TYPE = 'tbl'"}, "not_a_tire.tir"),
         ["not_a_tire.tir", "FILE_TYPE", "line 2"]),
        (write_variant(tmp_path, {"PKY1": "PKY1 = -15.3x"}, "bad_line.tir"),
         ["bad_line.tir", "line 74", "PKY1", "-15.3x"]),
        (write_variant(tmp_path, {"PKY1": None}, "no_pky1.tir"), ["no_pky1.tir", "PKY1"]),
        (write_variant(tmp_path, {"FNOMIN": "FNOMIN = -4000"}, "negative_load.tir"),
         ["negative_load.tir", "Fz0", "-4200", "FNOMIN = -4000"]),
        (write_variant(tmp_path, {"LATERAL_STIFFNESS": "LATERAL_STIFFNESS = 1e7"}, "short_sigma.tir"),
         ["short_sigma.tir", "sigmaTread"]),
    ]


def test_a_file_that_cannot_be_used_is_an_error_that_names_it(fmu, slaves, tmp_path):
    defaults = fc.start_values(fmu[0])
    for path, words in bad_files(tmp_path):
        log = fc.LogCapture()
        s = slaves(init=False, log=log)
        model = "SecondOrder" if path.name == "short_sigma.tir" else "RLT"
        status = with_file(s, path, model=model)
        assert status == fc.FMI2_ERROR, (path, log.text())
        errors = "\n".join(log.errors())
        for word in words:
            assert word in errors, (path.name, word, errors)
        # Nothing changed, and the instance recovers by a reset.
        assert values(s, ["Calpha"])["Calpha"] == defaults["Calpha"]
        s.reset()
        fc.initialise(s, "RLT", inputs={"vx": 5.0, "vy": 0.1})
        s.doStep(0.0, 0.01)
        assert math.isfinite(s.getReal([fc.OUTPUT_VR["Fy"]])[0])


def test_tir_file_is_fixed_after_initialisation(slaves):
    log = fc.LogCapture()
    s = slaves(init=False, log=log)
    assert with_file(s, PAC2002) == fc.FMI2_OK
    status, _ = fc.status_of(s.setString, [TIR_VR], [str(MF61)])
    assert status == fc.FMI2_ERROR and "tirFile" in "\n".join(log.errors())
    status, _ = fc.status_of(s.setString, [TIR_VR], [str(PAC2002)])
    assert status == fc.FMI2_OK


def test_the_mapping_command_prints_the_sources_and_writes_a_parameter_set(tmp_path):
    from fmpy.ssp.ssd import read_ssv

    ssv = tmp_path / "mf61.ssv"
    run = subprocess.run([str(REPO / "scripts" / "tir"), str(MF61), "--ssv", str(ssv)],
                         capture_output=True, text=True, check=True)
    expected = expected_mapping(MF61)
    for name, value in expected.items():
        line = next(l for l in run.stdout.splitlines() if l.split()[:1] == [name])
        assert f"{name} = " in line and "line" in line, line
        assert float(line.split()[1]) == pytest.approx(value, rel=1e-5), line
    assert "PKY4 = 1.9 is not 2" in run.stdout
    written = {p.name: float(p.value) for p in read_ssv(str(ssv)).parameters}
    assert set(written) == set(expected)
    for name, value in expected.items():
        tolerance = 1e-6 if name == "calphaLoadPeak" else 1e-12
        assert written[name] == pytest.approx(value, rel=tolerance), name
    bad = subprocess.run([str(REPO / "scripts" / "tir"), str(tmp_path / "none.tir")],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "none.tir" in bad.stderr


@pytest.mark.parametrize("fmi", ["fmi2", "fmi3"])
def test_the_vehicle_example_runs_on_the_property_file(tmp_path, fmu_path, fmi):
    """examples/tire_from_file.py, on either FMU: the snowblower's step steer on RLT tires
    from the project's PAC2002 file equals the run on tires set parameter by parameter (to
    1e-12 of the gain) once the file's pneumatic trail is set to the paper's 0 by the
    importer; with the file's trail the self-aligning moments add understeer (a lower
    steady gain)."""
    import sys

    sys.path.insert(0, str(REPO / "examples"))
    import tire_from_file as example

    fmu = fmu_path if fmi == "fmi2" else str(REPO / "target" / "fmu" / "fmi3" / "TireLag.fmu")
    res = example.main(["--fmu", fmu, "--quick", "--out-dir", str(tmp_path)])
    base = res["step"]["parameters"][1]
    assert np.max(np.abs(res["step"]["file, trail 0"][1] - base)) <= 1e-12 * np.max(np.abs(base))
    assert res["step"]["file"][1][-1] < base[-1] - 1e-4
    assert res["tires"]["file"]["trail"] == pytest.approx(0.05, rel=1e-12)
    assert (tmp_path / "tire_from_file.png").stat().st_size > 0
