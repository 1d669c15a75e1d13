"""Worker process for the cross-process FMU-state test (test_fmi_state.py).

    python fmi4_state_worker.py save OUTDIR   # per model: run, serialize, continue
    python fmi4_state_worker.py load OUTDIR   # per model: fresh instance, restore, continue

For each case <model>-<law> of fmi4_common.STATE_CASES (every model without a friction
limit, and with Coulomb and Brush friction low enough to slide):
save: initialise with non-default parameters, drive WARMUP steps of the deterministic
      sequence, serialize the FMU state to OUTDIR/<case>.state (and the time to
      <case>.json), then drive CONTINUE more steps and save the outputs to
      <case>.save.npy.
load: a fresh, only-instantiated instance (default parameters, never initialised)
      deserializes <case>.state, sets it, drives the same CONTINUE steps from the saved
      time and saves the outputs to <case>.load.npy, plus the parameters, model and
      friction law it reads back to <case>.load.json.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import fmi4_common as fc  # noqa: E402

WARMUP = 300
CONTINUE = 1000
SEED = 20240611


def sequence():
    return fc.input_sequence(WARMUP + CONTINUE, SEED)


def save(outdir: Path):
    md = fc.read_md()
    seq = sequence()
    with tempfile.TemporaryDirectory() as tmp:
        unzipdir = fc.extract_fmu(tmp)
        for model, law in fc.STATE_CASES:
            case = f"{model}-{law}"
            s = fc.new_slave(md, unzipdir, name=f"save-{case}")
            params = fc.STATE_PARAMS if law == "Unlimited" else {**fc.STATE_PARAMS, **fc.STATE_FRICTION_PARAMS}
            fc.initialise(s, model, params, friction=law)
            _, t = fc.drive(s, 0.0, seq, 0, WARMUP)
            state = s.getFMUstate()
            blob = s.serializeFMUstate(state)
            s.freeFMUstate(state)
            (outdir / f"{case}.state").write_bytes(blob)
            (outdir / f"{case}.json").write_text(json.dumps({"t": repr(t)}))
            Y, _ = fc.drive(s, t, seq, WARMUP, WARMUP + CONTINUE)
            np.save(outdir / f"{case}.save.npy", Y)
            fc.close(s)


def load(outdir: Path):
    md = fc.read_md()
    seq = sequence()
    with tempfile.TemporaryDirectory() as tmp:
        unzipdir = fc.extract_fmu(tmp)
        for model, law in fc.STATE_CASES:
            case = f"{model}-{law}"
            t = float(json.loads((outdir / f"{case}.json").read_text())["t"])
            blob = (outdir / f"{case}.state").read_bytes()
            s = fc.new_slave(md, unzipdir, name=f"load-{case}")   # only instantiated
            state = s.deSerializeFMUstate(blob)
            s.setFMUstate(state)
            s.freeFMUstate(state)
            readback = fc.configuration_readback(s.getInteger, s.getReal, fc.PARAMETER_VR)
            Y, _ = fc.drive(s, t, seq, WARMUP, WARMUP + CONTINUE)
            np.save(outdir / f"{case}.load.npy", Y)
            (outdir / f"{case}.load.json").write_text(json.dumps(readback))
            fc.close(s)


if __name__ == "__main__":
    mode, outdir = sys.argv[1], Path(sys.argv[2])
    {"save": save, "load": load}[mode](outdir)
