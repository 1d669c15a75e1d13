#!/usr/bin/env python3
"""Parameter sweep on Dask: the snowblower's yaw mode over sigmaY x speed x tire model.

Each grid point is one co-simulation of Koo & Tan's snowblower (the vehicle of
snowblower_standstill.py; DDT in the improved bicycle model, RLT in the bicycle model with
RLT) with the tire's lateral relaxation length sigmaY changed. Calpha stays at 350000
N/rad, so the lateral stiffness C_lat = Calpha/sigmaY changes with it: this is Koo &
Tan's Fig 4(c), where sigma_lat sets the frequency of the yaw mode (about 0.8 Hz near
1 m).

The body is released with a small lateral and yaw velocity and rolls freely for 20 s; the
Eigensystem Realization Algorithm (cosim.frequency.era_poles) finds the poles of the
co-simulated free response, and the yaw mode is the oscillatory mode whose motion is
mostly yaw (the larger share of kinetic energy in I r^2 rather than M v^2); the other is
the lateral mode. A free response rather than a steer input, because with RLT at 0 m/s
steering excites nothing (the null gain) and the modes are undamped.

Runs on an embedded dask.distributed LocalCluster (2 worker processes by default), on an
existing cluster with --scheduler ADDRESS, or in this process with --serial; the three
give the same numbers bit for bit. The FMU goes to the workers once (scattered), and
each worker process unpacks it once, however many runs it does (cosim.tire.load_fmu
caches the extraction by content hash). The cosim package and this script are uploaded
to the workers (Client.upload_file), so a remote cluster needs only the Python packages
of requirements.txt.

Writes out/sweep.csv (model, sigmaY [m], speed [m/s], yaw and lateral mode frequency
[Hz] and damping ratio [1]) and out/sweep.png (heatmaps of the yaw-mode frequency and
damping ratio over speed and sigmaY, one row per tire model).

    .venv/bin/python examples/sweep.py                      # LocalCluster, 2 workers
    .venv/bin/python examples/sweep.py --serial             # no Dask
    # a cluster: HOST is the scheduler machine's address on the cluster's network, WORKER
    # each worker machine's own (127.0.0.1 for both on one machine, nothing else reaches it)
    .venv/bin/dask scheduler --host HOST --dashboard-address HOST:8787
    .venv/bin/dask worker tcp://HOST:8786 --host WORKER --dashboard-address WORKER:0
    .venv/bin/python examples/sweep.py --scheduler tcp://HOST:8786

Either FMU works (--fmu target/fmu/fmi3/TireLag.fmu for FMI 3.0; see cosim/tire.py for
what FMI 3.0's missing input derivatives change).
"""

from __future__ import annotations

import hashlib
import importlib
import itertools
import logging
import math
import os
import sys
import tempfile
import threading
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from cosim import CoSimulation, era_poles, extraction_count, load_fmu, snowblower  # noqa: E402
from cosim.cli import output_paths, parser, print_table, write_csv  # noqa: E402
from cosim.vehicle import SNOWBLOWER_BODY  # noqa: E402

NAME = "sweep"
MODELS = ("RLT", "DDT")
SIGMA_Y = (0.5, 0.75, 1.0, 1.25, 1.5)          # m
SPEEDS = (0.0, 0.45, 0.9, 1.6, 2.5)             # m/s
QUICK_SIGMA_Y = (1.0, 1.5)
QUICK_SPEEDS = (0.0, 1.6)
STEP = 0.01            # s, communication step of each run
DURATION = 20.0        # s of free response
RELEASE = {"v": 0.01, "r": 0.01}   # m/s, rad/s: the initial body velocities
ORDER = 4              # v, r and the two axles' deflections; the yaw deflection is not excited
COLUMNS = ("model", "sigmaY_m", "speed_m_per_s", "yaw_frequency_Hz", "yaw_damping",
           "lateral_frequency_Hz", "lateral_damping")


@dataclass(frozen=True)
class FMUPayload:
    """The FMU's bytes, sent to the workers once (Client.scatter)."""

    sha256: str
    data: bytes

    @classmethod
    def read(cls, path) -> "FMUPayload":
        data = Path(path).read_bytes()
        return cls(hashlib.sha256(data).hexdigest(), data)


_WRITTEN: dict[str, str] = {}   # sha256 -> where this process wrote the payload
# A worker with several threads (dask worker's default) runs several cases at once: one file.
_WRITING = threading.Lock()


def _fmu(source):
    """The extracted FMU for a path or a payload; a payload is written to disk once per
    process, and load_fmu unpacks it once per process."""
    if isinstance(source, FMUPayload):
        with _WRITING:
            path = _WRITTEN.get(source.sha256)
            if path is None:
                folder = tempfile.mkdtemp(prefix=f"tirelag-sweep-{os.getpid()}-")
                path = os.path.join(folder, f"TireLag-{source.sha256[:16]}.fmu")
                with open(path, "wb") as f:
                    f.write(source.data)
                _WRITTEN[source.sha256] = path
        return load_fmu(path)
    return load_fmu(source)


def grid(sigmas=SIGMA_Y, speeds=SPEEDS, models=MODELS) -> list[dict]:
    return [{"model": m, "sigmaY": float(s), "speed": float(v)}
            for m, s, v in itertools.product(models, sigmas, speeds)]


def run_case(fmu_source, case: dict) -> dict:
    """One co-simulation: the snowblower's free response, and its two modes."""
    fmu = _fmu(fmu_source)
    with snowblower(fmu, case["model"], case["speed"], {"sigmaY": case["sigmaY"]}) as vehicle:
        N = int(round(DURATION / STEP))
        traj = CoSimulation(vehicle, STEP).run(np.zeros((N + 1, len(vehicle.external_names))), x0=RELEASE)
    poles, shapes = era_poles(traj.states, STEP, ORDER)
    body = SNOWBLOWER_BODY
    modes = []
    for p, shape in zip(poles, shapes.T):
        if p.imag > 0:
            v, r = shape
            yaw_share = body.yaw_inertia * abs(r) ** 2 / (body.mass * abs(v) ** 2 + body.yaw_inertia * abs(r) ** 2)
            modes.append((yaw_share, abs(p) / (2 * math.pi), -p.real / abs(p)))
    if len(modes) != 2:
        raise RuntimeError(f"{case}: expected two oscillatory modes, found poles {poles}")
    lateral, yaw = sorted(modes)
    return {"model": case["model"], "sigmaY_m": case["sigmaY"], "speed_m_per_s": case["speed"],
            "yaw_frequency_Hz": float(yaw[1]), "yaw_damping": float(yaw[2]),
            "lateral_frequency_Hz": float(lateral[1]), "lateral_damping": float(lateral[2]),
            "worker_pid": os.getpid(), "fmu_extractions": extraction_count()}


# --------------------------------------------------------------------------- running

def _code_archive(folder: Path) -> Path:
    """cosim/ as a zip, importable where it is uploaded."""
    path = folder / "cosim.zip"
    with zipfile.ZipFile(path, "w") as z:
        for src in sorted((HERE / "cosim").glob("*.py")):
            z.write(src, f"cosim/{src.name}")
    return path


def run_serial(cases: list[dict], fmu_path) -> list[dict]:
    rows = []
    for i, case in enumerate(cases, 1):
        rows.append(run_case(str(fmu_path), case))
        print(f"\r[{'#' * (40 * i // len(cases)):<40}] {i}/{len(cases)} runs", end="", flush=True)
    print()
    return rows


def run_dask(cases: list[dict], fmu_path, scheduler: str | None = None, workers: int = 2) -> list[dict]:
    """Run the cases on a LocalCluster of `workers` processes, or on the cluster at
    `scheduler`; results in the order of `cases`."""
    from distributed import Client, LocalCluster, progress
    from distributed.diagnostics.plugin import UploadFile

    cluster = None
    if scheduler is None:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
        client = Client(cluster)
    else:
        client = Client(scheduler)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            for code in (_code_archive(Path(tmp)), Path(__file__).resolve()):   # cosim first: this module imports it
                if cluster is None:
                    client.upload_file(str(code))       # the scheduler unpickles the tasks: it needs the code too
                else:
                    # A LocalCluster's scheduler runs in this process, which has the code;
                    # upload_file would reload this module and cosim there from its scratch
                    # folder, deleted with the cluster (a second run would then fail).
                    client.register_plugin(UploadFile(str(code)), name=f"upload {code.name}")
        # run_case and FMUPayload by this file's module name (also when it runs as
        # __main__), so that the workers use them from the upload
        task = importlib.import_module("sweep")
        payload = client.scatter(task.FMUPayload.read(fmu_path), broadcast=True)
        futures = [client.submit(task.run_case, payload, case, pure=False) for case in cases]
        progress(futures)
        print()
        return client.gather(futures)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


# --------------------------------------------------------------------------- output

def report(rows: list[dict]) -> None:
    table = [[r["model"], r["sigmaY_m"], r["speed_m_per_s"], r["yaw_frequency_Hz"], r["yaw_damping"],
              r["lateral_frequency_Hz"], r["lateral_damping"]] for r in rows]
    print_table("Snowblower yaw and lateral modes (free response, ERA):",
                ["model", "sigmaY [m]", "speed [m/s]", "yaw [Hz]", "yaw zeta", "lateral [Hz]", "lateral zeta"],
                table, {1: "{:g}", 2: "{:g}", 3: "{:.3f}", 4: "{:.4f}", 5: "{:.3f}", 6: "{:.4f}"})
    pids = {}
    for r in rows:
        pids.setdefault(r["worker_pid"], []).append(r["fmu_extractions"])
    for pid, counts in sorted(pids.items()):
        print(f"  process {pid}: {len(counts)} runs, FMU unpacked {max(counts)} time(s)")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sigmas = sorted({r["sigmaY_m"] for r in rows})
    speeds = sorted({r["speed_m_per_s"] for r in rows})
    models = [m for m in MODELS if any(r["model"] == m for r in rows)]
    fig, axes = plt.subplots(len(models), 2, figsize=(11, 4.2 * len(models)), constrained_layout=True,
                             squeeze=False)
    for i, model in enumerate(models):
        for j, (key, label, fmt) in enumerate((("yaw_frequency_Hz", "yaw-mode frequency [Hz]", "{:.3f}"),
                                               ("yaw_damping", "yaw-mode damping ratio [1]", "{:.3f}"))):
            Z = np.full((len(sigmas), len(speeds)), np.nan)
            for r in rows:
                if r["model"] == model:
                    Z[sigmas.index(r["sigmaY_m"]), speeds.index(r["speed_m_per_s"])] = r[key]
            ax = axes[i, j]
            im = ax.imshow(Z, origin="lower", aspect="auto", cmap="viridis")
            for (a, b), value in np.ndenumerate(Z):
                ax.text(b, a, fmt.format(value), ha="center", va="center", fontsize=8,
                        color="w" if value < np.nanmean(Z) else "k")
            ax.set_xticks(range(len(speeds)), [f"{v:g}" for v in speeds])
            ax.set_yticks(range(len(sigmas)), [f"{s:g}" for s in sigmas])
            ax.set_xlabel("speed [m/s]")
            ax.set_ylabel("lateral relaxation length sigmaY [m]")
            ax.set_title(f"{model}: {label}")
            fig.colorbar(im, ax=ax, label=label)
    fig.suptitle("Koo & Tan snowblower, yaw mode over sigmaY and speed (Calpha fixed, so C_lat = Calpha/sigmaY)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write(rows: list[dict], path: Path) -> None:
    write_csv(path, COLUMNS, [[r[c] for c in COLUMNS] for r in rows])


def main(argv=None) -> list[dict]:
    p = parser(__doc__.split("\n\n")[0])
    p.add_argument("--scheduler", metavar="ADDRESS", help="run on this Dask scheduler (tcp://host:8786)")
    p.add_argument("--workers", type=int, default=2, help="worker processes of the LocalCluster (default 2)")
    p.add_argument("--serial", action="store_true", help="run the grid in this process, without Dask")
    args = p.parse_args(argv)
    cases = grid(QUICK_SIGMA_Y, QUICK_SPEEDS) if args.quick else grid()
    start = time.perf_counter()
    if args.serial:
        print(f"{len(cases)} co-simulations in this process")
        rows = run_serial(cases, args.fmu)
    else:
        where = args.scheduler or f"a LocalCluster of {args.workers} worker processes"
        print(f"{len(cases)} co-simulations on {where}")
        rows = run_dask(cases, args.fmu, args.scheduler, args.workers)
    print(f"  {time.perf_counter() - start:.1f} s")
    png, csv_path = output_paths(args.out_dir, NAME)
    report(rows)
    write(rows, csv_path)
    plot(rows, png)
    print(f"wrote {png}\nwrote {csv_path}")
    return rows


if __name__ == "__main__":
    main()
