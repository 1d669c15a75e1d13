"""The documentation checks: scripts/check-docs on README.md and docs/**/*.md.

The first test is the check itself: every relative link, image and #anchor resolves, every
path named in code exists, every "docs/specification.md N" names a section, and every
```python block that states what it prints prints it (a few seconds: the blocks run the
packed FMUs, target/fmu/TireLag.fmu and target/fmu/fmi3/TireLag.fmu). The others hold the
checker to its rules on small pages of their own, so that a wrong number, a broken link or
a missing path is reported with its file and line.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
CHECKER = REPO / "scripts" / "check-docs"
FMU = REPO / "target" / "fmu" / "TireLag.fmu"
FMU3 = REPO / "target" / "fmu" / "fmi3" / "TireLag.fmu"


def check(*args: str | Path, timeout: float = 240) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(CHECKER), *map(str, args)], cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)


def page(tmp_path: Path, text: str, name: str = "page.md") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return path


def test_readme_and_docs_pass_the_check():
    for fmu in (FMU, FMU3):
        if not fmu.exists():
            pytest.fail(f"{fmu} is missing: run ./scripts/build-fmu --native first")
    run = check()
    assert run.returncode == 0, f"scripts/check-docs found problems:\n{run.stdout}{run.stderr}"
    summary = run.stdout.strip().splitlines()[-1]
    assert "blocks run" in summary and "numbers compared" in summary, summary


def test_a_number_that_was_not_printed_names_file_line_and_number(tmp_path):
    md = page(tmp_path, """
        # A page

        ```python
        print("Fy =", 3500.04, "N")
        print(-175.0)
        ```

        This prints:

        ```text
        Fy = 3500.0 N
        -175.1
        ```
        """)
    run = check(md)
    assert run.returncode == 1, run.stdout
    assert f"{md}:12: stated -175.1 (to the digits shown: ±0.05)" in run.stdout, run.stdout
    assert "nearest: -175.0" in run.stdout, run.stdout
    assert f"{md}:11:" not in run.stdout, run.stdout        # 3500.0 matches 3500.04


def test_numbers_must_come_in_order_and_a_tolerance_can_be_stated(tmp_path):
    md = page(tmp_path, """
        ```python
        print(2.0, 1.0)
        print(100.4)
        ```

        ```text rtol=0.01
        1.0 2.0
        100
        ```

        ```python
        print(1.2345)   # prints (rtol=1e-3): 1.2346
        print(7.06)     # prints: 7.0
        ```
        """)
    run = check(md)
    assert run.returncode == 1, run.stdout
    problems = [line for line in run.stdout.splitlines() if line.startswith(str(md))]
    # 1.0 matches the printed 1.0; 2.0 then has only 100.4 after it
    assert len(problems) == 2, run.stdout
    assert problems[0].startswith(f"{md}:7: stated 2.0 (within rtol=0.01)"), run.stdout
    assert problems[1].startswith(f"{md}:13: stated 7.0 (to the digits shown: ±0.05)"), run.stdout


def test_a_block_that_fails_is_reported(tmp_path):
    md = page(tmp_path, """
        ```python
        raise SystemExit("no FMU here")   # prints: 1
        ```
        """)
    run = check(md)
    assert run.returncode == 1
    assert f"{md}:1: the python block exited with 1" in run.stdout, run.stdout
    assert "no FMU here" in run.stdout, run.stdout


def test_links_anchors_and_paths_in_code_are_checked(tmp_path):
    page(tmp_path, "# Other page\n\n## Some heading: with `code`\n", "other.md")
    md = page(tmp_path, """
        # Page

        [good](other.md#some-heading-with-code) and [good too](#page),
        [missing file](nothere.md), [missing
        anchor](other.md#no-such-heading), ![missing image](fig.png).

        Run `scripts/no-such-script` or `scripts/check-docs`; docs/specification.md 99z.

        ```sh
        ./scripts/check-docs --no-run       # exists
        .venv/bin/python examples/not_an_example.py
        ```
        """)
    run = check(md, "--no-run")
    assert run.returncode == 1
    out = run.stdout
    assert f"{md}:4: link 'nothere.md'" in out, out
    assert f"{md}:4: link 'other.md#no-such-heading'" in out and "has no heading" in out, out
    assert f"{md}:5: image 'fig.png'" in out, out
    assert f"{md}:7: path 'scripts/no-such-script'" in out, out
    assert f"{md}:7: docs/specification.md has no section 99z" in out, out
    assert f"{md}:11: path 'examples/not_an_example.py'" in out, out
    assert "#page" not in out and "some-heading-with-code" not in out, out
    assert "scripts/check-docs'" not in out, out
    assert len([line for line in out.splitlines() if line.startswith(str(md))]) == 6, out
