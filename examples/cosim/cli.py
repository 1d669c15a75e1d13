"""What the example scripts share: the command line, the output folder, CSV writing."""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path
from typing import Iterable, Mapping, Sequence

from .tire import default_fmu_path

PROJECT = Path(__file__).resolve().parents[2]


def parser(description: str) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=description,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fmu", type=Path, default=default_fmu_path(),
                   help="TireLag FMU (default: $TIRELAG_FMU, else target/fmu/TireLag.fmu "
                        "in the project)")
    p.add_argument("--quick", action="store_true",
                   help="a shorter run with coarser settings (for the tests)")
    p.add_argument("--out-dir", type=Path, default=PROJECT / "out",
                   help="where the PNG and CSV go (default: out/ in the project; created if missing)")
    return p


def run_example(description: str, name: str, simulate, report, write, plot, argv=None) -> dict:
    """The body of an example's main: parse the command line, simulate, print what it
    reproduces, and write <name>.csv and <name>.png under the output folder."""
    args = parser(description).parse_args(argv)
    res = simulate(args.fmu, args.quick)
    png, csv_path = output_paths(args.out_dir, name)
    report(res)
    write(res, csv_path)
    plot(res, png)
    print(f"wrote {png}\nwrote {csv_path}")
    return res


def output_paths(out_dir: Path, name: str) -> tuple[Path, Path]:
    """(<out_dir>/<name>.png, <out_dir>/<name>.csv), creating out_dir."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    return out_dir / f"{name}.png", out_dir / f"{name}.csv"


def write_csv(path: Path, header: Sequence[str], rows: Iterable[Sequence]) -> None:
    """A CSV with full float precision (repr), so that numbers read back bit for bit."""
    def cell(v):
        # numpy floats are floats too, but their repr names the type (np.float64(0.5)).
        if isinstance(v, float):
            return repr(float(v)) if math.isfinite(v) else str(float(v))
        return v

    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for row in rows:
            w.writerow([cell(v) for v in row])


def read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def print_table(title: str, header: Sequence[str], rows: Iterable[Sequence], formats: Mapping[int, str] | None = None):
    rows = [list(r) for r in rows]
    formats = formats or {}
    text = [[(formats.get(i, "{}").format(v) if not isinstance(v, str) else v) for i, v in enumerate(r)]
            for r in rows]
    widths = [max(len(str(h)), *(len(r[i]) for r in text)) for i, h in enumerate(header)]
    print(title)
    print("  " + "  ".join(str(h).rjust(w) for h, w in zip(header, widths)))
    for r in text:
        print("  " + "  ".join(c.rjust(w) for c, w in zip(r, widths)))
