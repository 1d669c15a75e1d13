"""The host of tests/platforms/host.c for the tests: building it, running it on a packed
binary, and reading and comparing what it prints (test_platforms.py, test_golden_run.py).
"""

import collections
import os
import pathlib
import shutil
import struct
import subprocess
import xml.etree.ElementTree as ET
import zipfile

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
HOST = ROOT / "tests" / "platforms" / "host.c"
FMU2 = ROOT / "target" / "fmu" / "TireLag.fmu"
FMU3 = ROOT / "target" / "fmu" / "fmi3" / "TireLag.fmu"
MODELS = {"1": "RLT", "2": "DDT", "3": "SecondOrder", "4": "RingBody"}
LAWS = {"1": "Unlimited", "2": "Coulomb", "3": "Brush"}
ALL_PLATFORMS = os.environ.get("TIRELAG_ALL_PLATFORMS") == "1"


def fmi_headers() -> pathlib.Path:
    import fmpy

    return pathlib.Path(fmpy.__file__).parent / "c-code"


def member(fmu: pathlib.Path, name: str) -> bytes | None:
    with zipfile.ZipFile(fmu) as archive:
        return archive.read(name) if name in archive.namelist() else None


def packed(fmu: pathlib.Path, name: str, tmp: pathlib.Path) -> pathlib.Path:
    data = member(fmu, name)
    if data is None:
        message = f"{fmu.relative_to(ROOT)} has no {name}"
        if ALL_PLATFORMS:
            pytest.fail(message + " (./scripts/build-fmu packs every platform)")
        pytest.skip(message + ": packed with --native")
    path = tmp / name.replace("/", "_")
    path.write_bytes(data)
    return path


def guid() -> str:
    root = ET.fromstring(member(FMU2, "modelDescription.xml"))
    return root.get("guid")


def native_host(tmp: pathlib.Path) -> pathlib.Path:
    """The host built for this machine (Linux x86_64)."""
    return compile_host(["cc"], tmp / "host", ["-ldl", "-lm"])


def run(command: list[str], cwd: pathlib.Path, env: dict | None = None) -> str:
    done = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=900)
    if done.returncode != 0:
        raise AssertionError(f"{' '.join(map(str, command))} failed ({done.returncode}):\n{done.stderr[-4000:]}")
    return done.stdout


def compile_host(compiler: list[str], output: pathlib.Path, libraries: list[str]) -> pathlib.Path:
    flags = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off", f"-I{fmi_headers()}"]
    run([*compiler, *flags, str(HOST), "-o", str(output), *libraries], cwd=output.parent)
    return output


def need(tool: str) -> str:
    found = shutil.which(tool) or (tool if pathlib.Path(tool).exists() else None)
    if not found:
        message = f"{tool} is not installed (./scripts/setup --all-platforms installs it)"
        if ALL_PLATFORMS:
            pytest.fail(message)
        pytest.skip(message)
    return found


class Run:
    """One host run: its rows by (case, model, law, step) and its costs per step."""

    def __init__(self, text: str):
        self.rows: dict[tuple, list[str]] = {}
        self.cost: dict[str, float] = {}
        for line in text.splitlines():
            words = line.split()
            if words[0] == "time":
                self.cost[words[1]] = float(words[2])
            else:
                self.rows[tuple(words[:4])] = words[4:]


def value(word: str) -> float:
    return struct.unpack(">d", bytes.fromhex(word))[0]


def is_value(word: str) -> bool:
    return len(word) == 16


def compare(reference: Run, other: Run):
    """Per (model, law): the largest relative difference, the differing values, their count."""
    assert reference.rows.keys() == other.rows.keys(), "the runs went through different cases"
    scale: dict[tuple, float] = collections.defaultdict(float)
    for (case, model, law, _), words in reference.rows.items():
        for column, word in enumerate(w for w in words if is_value(w)):
            scale[case, model, law, column] = max(scale[case, model, law, column], abs(value(word)))
    largest = collections.defaultdict(float)
    differing = collections.Counter()
    for key, words in reference.rows.items():
        theirs = other.rows[key]
        if words == theirs:
            continue
        case, model, law, _ = key
        if case == "st2":  # the serialised state: bytes, read in the note of the table
            differing[model, law, "state"] += 1
            continue
        column = 0
        for ours, its in zip(words, theirs, strict=True):
            if not is_value(ours):
                assert ours == its, f"{key}: {ours} against {its}"
                continue
            if ours != its:
                a, b = value(ours), value(its)
                difference = abs(a - b) / scale[case, model, law, column] if scale[case, model, law, column] else 0.0
                if a != a or b != b:
                    difference = float("inf")
                largest[model, law] = max(largest[model, law], difference)
                differing[model, law, "values"] += 1
            column += 1
    return largest, differing


