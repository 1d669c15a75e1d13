"""Every runnable binary of the two FMUs gives the Linux x86_64 results (docs/specification.md 1b).

tests/platforms/host.c drives one binary through the same cases (every model and law:
sticking, sliding, vx through zero, lift-off and touchdown, standstill steering, long steps,
a stiff tire at a light load, FMU state restored and deserialised, Model Exchange
evaluation and event updates; FMI 2.0 and FMI 3.0) and prints every value bit for bit. It is built natively for Linux x86_64,
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
import shutil
import sys

import pytest
from platform_host import (
    FMU2,
    FMU3,
    LAWS,
    MODELS,
    ROOT,
    Run,
    compare,
    compile_host,
    guid,
    is_value,
    member,
    native_host,
    need,
    packed,
    run,
    value,
)

REPORT = ROOT / "target" / "platforms" / "comparison.md"

@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The Linux x86_64 run and the run of each other runnable platform."""
    tmp = tmp_path_factory.mktemp("platforms")
    token = guid()
    results = {}

    native_library = packed(FMU2, "binaries/linux64/TireLag.so", tmp)
    native = native_host(tmp)
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
    need(sysroot + "/lib/ld-linux-aarch64.so.1")  # libc6-arm64-cross
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
def test_platform_gives_the_linux_x86_64_results_bit_for_bit(runs, platform):
    """The physics computes its elementary functions itself (src/physics/math.rs), so no
    platform's C library rounds them differently: every value is the same bits."""
    largest, differing = compare(runs["Linux x86_64"], runs[platform])
    worst = max(largest.values(), default=0.0)
    assert not differing, f"{platform}: {dict(differing)} differ, by at most {worst:.3g} relative"


@pytest.mark.parametrize("platform", ["Linux x86_64", "Windows x86_64 (wine)", "Linux aarch64 (qemu-user)"])
def test_fmi3_equals_fmi2_on_every_platform(runs, platform):
    """FMI 3.0 Co-Simulation steps, Model Exchange evaluations and event updates give the
    FMI 2.0 values bit for bit."""
    rows = runs[platform].rows
    for fmi3_case, fmi2_case, count in [("cs3", "cs2", 12 * 500), ("me3", "me2", 12 * 4000), ("ev3", "ev2", None)]:
        fmi3 = {key: words for key, words in rows.items() if key[0] == fmi3_case}
        fmi2 = {key: words for key, words in rows.items() if key[0] == fmi2_case}
        assert len(fmi3) == (count or len(fmi2)), fmi3_case
        for (_, model, law, step), words in fmi3.items():
            assert words == rows[fmi2_case, model, law, step], f"{platform}: {fmi3_case} model {model} law {law} step {step}"


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
