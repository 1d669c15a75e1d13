"""The golden run: what the packed Linux x86_64 binary returns in the cases of
tests/platforms/host.c (every model and law; FMI 2.0 and 3.0 Co-Simulation and Model
Exchange; sticking, sliding, vx through zero, lift-off and touchdown, standstill steering,
0.25 s steps, a stiff tire at a light load, FMU states restored and deserialised, event
updates), held bit for bit to tests/data/golden_run.txt.

Each case is cut into blocks of 100 steps, and the file keeps the SHA-256 of each block's
printed values, so a difference is named down to its block. A change of the code that is
not meant to change any result (a move, a rename, a new layout) must leave every block as
it is. A change that is meant to change results records the file anew:

    TIRELAG_RECORD_GOLDEN=1 .venv/bin/python -m pytest tests/python/test_golden_run.py

and its commit says which blocks changed and why.
"""

import collections
import hashlib
import os

from platform_host import FMU2, ROOT, guid, native_host, packed, run

GOLDEN = ROOT / "tests" / "data" / "golden_run.txt"
BLOCK = 100


def digests(text: str) -> dict[str, str]:
    """'case model law first-step' -> SHA-256 of the block's lines, in the host's order."""
    blocks: dict[str, list[str]] = collections.defaultdict(list)
    for line in text.splitlines():
        words = line.split()
        if words[0] == "time":
            continue
        case, model, law, step = words[:4]
        blocks[f"{case} {model} {law} {int(step) // BLOCK * BLOCK}"].append(line)
    return {key: hashlib.sha256("\n".join(lines).encode()).hexdigest() for key, lines in blocks.items()}


def read_golden() -> dict[str, str]:
    entries = {}
    for line in GOLDEN.read_text().splitlines():
        if line and not line.startswith("#"):
            *key, digest = line.split()
            entries[" ".join(key)] = digest
    return entries


def test_the_binary_gives_the_golden_run(tmp_path):
    library = packed(FMU2, "binaries/linux64/TireLag.so", tmp_path)
    now = digests(run([str(native_host(tmp_path)), "-g", guid(), str(library)], cwd=tmp_path))
    if os.environ.get("TIRELAG_RECORD_GOLDEN") == "1":
        header = "# case model law first-step sha256 (tests/python/test_golden_run.py)\n"
        GOLDEN.write_text(header + "".join(f"{key} {digest}\n" for key, digest in sorted(now.items())))
    golden = read_golden()
    assert len(golden) > 1000, "the golden file holds too few blocks"
    assert now.keys() == golden.keys(), (
        f"cases added {sorted(now.keys() - golden.keys())[:5]}, missing {sorted(golden.keys() - now.keys())[:5]}"
    )
    changed = sorted((key for key in golden if golden[key] != now[key]), key=lambda k: (k.split()[:3], int(k.split()[3])))
    assert not changed, f"{len(changed)} blocks differ from the golden run, first: {changed[:10]}"
