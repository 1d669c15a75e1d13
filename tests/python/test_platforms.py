"""Every runnable binary of the two FMUs gives the Linux x86_64 results (SPEC 1b).

tests/platforms/host.c drives one binary through the same cases (every model and law:
sticking, sliding, vx through zero, lift-off and touchdown, standstill steering, long steps,
FMU state restored and deserialised, Model Exchange evaluation and event updates, FMI 3.0
Co-Simulation) and prints every value bit for bit. It is built natively for Linux x86_64,
with mingw-w64 for Windows (run under wine) and with zig for Linux aarch64 (run under
qemu-user), and each run is compared value by value with the Linux x86_64 one. macOS
binaries cannot run here; tests/platform_binaries.rs reads their Mach-O files instead.

The comparison table (largest difference per platform, model and law, and the cost per
step under each emulator beside native) is written to target/platforms/comparison.md.

Without every binary packed (./scripts/build-fmu --native) these tests skip; under
./scripts/test (TIRELAG_ALL_PLATFORMS=1) a missing binary fails.
"""

import collections
import os
import pathlib
import shutil
import struct
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
HOST = ROOT / "tests" / "platforms" / "host.c"
FMU2 = ROOT / "target" / "fmu" / "TireLag.fmu"
FMU3 = ROOT / "target" / "fmu" / "fmi3" / "TireLag.fmu"
REPORT = ROOT / "target" / "platforms" / "comparison.md"
MODELS = {"1": "RLT", "2": "DDT", "3": "SecondOrder", "4": "RingBody"}
LAWS = {"1": "Unlimited", "2": "Coulomb", "3": "Brush"}
# Relative to the largest magnitude of the same value over the same case on Linux x86_64.
TOLERANCE = 1e-12
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


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The Linux x86_64 run and the run of each other runnable platform."""
    tmp = tmp_path_factory.mktemp("platforms")
    token = guid()
    results = {}

    native_library = packed(FMU2, "binaries/linux64/TireLag.so", tmp)
    native = compile_host(["cc"], tmp / "host", ["-ldl", "-lm"])
    results["Linux x86_64"] = Run(run([str(native), "-T", "-g", token, str(native_library)], cwd=tmp))

    windows = tmp / "windows"
    windows.mkdir()
    dll = packed(FMU2, "binaries/win64/TireLag.dll", tmp)
    assert dll.read_bytes() == member(FMU3, "binaries/x86_64-windows/TireLag.dll")
    shutil.copy(dll, windows / "TireLag.dll")
    compile_host([need("x86_64-w64-mingw32-gcc-win32")], windows / "host.exe", [])
    wine = need("/usr/lib/wine/wine64")
    prefix = ROOT / "target" / "platforms" / "wine"
    prefix.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, WINEPREFIX=str(prefix), WINEDEBUG="-all", WINEDLLOVERRIDES="mscoree,mshtml=")
    results["Windows x86_64 (wine)"] = Run(run([wine, "host.exe", "-T", "-g", token, "TireLag.dll"], windows, env))

    aarch64_library = packed(FMU3, "binaries/aarch64-linux/TireLag.so", tmp)
    zig = [sys.executable, "-m", "ziglang", "cc", "-target", "aarch64-linux-gnu.2.17"]
    aarch64 = compile_host(zig, tmp / "host-aarch64", ["-ldl", "-lm"])
    qemu = need("qemu-aarch64")
    sysroot = "/usr/aarch64-linux-gnu"
    if not pathlib.Path(sysroot, "lib", "ld-linux-aarch64.so.1").exists():
        need(sysroot + "/lib/ld-linux-aarch64.so.1")
    results["Linux aarch64 (qemu-user)"] = Run(
        run([qemu, "-L", sysroot, str(aarch64), "-T", "-g", token, str(aarch64_library)], cwd=tmp)
    )
    write_report(results)
    return results


def write_report(results: dict[str, Run]) -> None:
    reference = results["Linux x86_64"]
    lines = [
        "# The same cases on every runnable platform, against Linux x86_64",
        "",
        "Largest difference of any value (outputs, derivatives, event indicators, states),",
        "relative to the largest magnitude of that value in the same case on Linux x86_64;",
        "0 is bit for bit. Made by tests/python/test_platforms.py.",
        "",
    ]
    platforms = [p for p in results if p != "Linux x86_64"]
    lines.append("| model | law | " + " | ".join(platforms) + " |")
    lines.append("|---|---|" + "---|" * len(platforms))
    compared = {p: compare(reference, results[p]) for p in platforms}
    for model, model_name in MODELS.items():
        for law, law_name in LAWS.items():
            cells = []
            for p in platforms:
                largest, differing = compared[p]
                count = differing[model, law, "values"]
                cell = "0" if not count else f"{largest[model, law]:.1e} ({count} values)"
                if differing[model, law, "state"]:
                    cell += ", state bytes differ"
                cells.append(cell)
            lines.append(f"| {model_name} | {law_name} | " + " | ".join(cells) + " |")
    lines += ["", "Cost per Co-Simulation step, Brush, h = 1 ms (ns; indicative: emulated)", ""]
    lines.append("| model | " + " | ".join(results) + " |")
    lines.append("|---|" + "---|" * len(results))
    for model, model_name in MODELS.items():
        lines.append(f"| {model_name} | " + " | ".join(f"{r.cost[model]:.0f}" for r in results.values()) + " |")
    REPORT.parent.mkdir(parents=True, exist_ok=True)
    REPORT.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("platform", ["Windows x86_64 (wine)", "Linux aarch64 (qemu-user)"])
def test_platform_gives_the_linux_x86_64_results(runs, platform):
    largest, differing = compare(runs["Linux x86_64"], runs[platform])
    worst = max(largest.values(), default=0.0)
    assert worst <= TOLERANCE, f"{platform}: largest relative difference {worst:.3g} ({dict(largest)})"
    # A state differs in its bytes only where the values before it differ.
    for model, law, what in differing:
        if what == "state":
            assert differing[model, law, "values"], f"{platform}: model {model} law {law}: state bytes differ alone"


def test_linux_aarch64_is_bit_for_bit(runs):
    """glibc's libm on aarch64 rounds as on x86_64: nothing may differ at all."""
    _, differing = compare(runs["Linux x86_64"], runs["Linux aarch64 (qemu-user)"])
    assert not differing, dict(differing)


@pytest.mark.parametrize("platform", ["Linux x86_64", "Windows x86_64 (wine)", "Linux aarch64 (qemu-user)"])
def test_fmi3_steps_equal_fmi2_steps_on_every_platform(runs, platform):
    rows = runs[platform].rows
    fmi3 = {key: words for key, words in rows.items() if key[0] == "cs3"}
    assert len(fmi3) == 12 * 500
    for (_, model, law, step), words in fmi3.items():
        assert words == rows["cs2", model, law, step], f"{platform}: model {model} law {law} step {step}"


def test_every_case_ran_with_events(runs):
    """The cases reach what they are for: events in Model Exchange, finite values everywhere."""
    reference = runs["Linux x86_64"]
    events = collections.Counter((m, law) for (case, m, law, _) in reference.rows if case == "ev2")
    for model in MODELS:
        for law in LAWS:
            assert events[model, law] >= 2, f"model {model} law {law}: {events[model, law]} event updates"
    for key, words in reference.rows.items():
        for word in words:
            if is_value(word):
                v = value(word)
                assert v == v and abs(v) != float("inf"), f"{key}: non-finite value"
