"""Worker process for the cross-process FMU-state test of the FMI 3.0 FMU (test_fmi3.py),
the FMI 3.0 counterpart of fmi4_state_worker.py.

    python fmi3_state_worker.py save OUTDIR   # per case: run, serialize, continue
    python fmi3_state_worker.py load OUTDIR   # per case: fresh instance, restore, continue

Cases: <interface>-<model>-<law> for interface cs (Co-Simulation, FMU3Slave, driven by
fmi3_common.drive3 on a piecewise-constant sequence) and me (Model Exchange, FMU3Model,
driven by fmi3_common.EulerME), and (model, law) in fmi4_common.STATE_CASES (every model
without a friction limit, and with Coulomb and Brush friction low enough to slide).
save: initialise with non-default parameters, run the warm-up, serialize the FMU state to
      OUTDIR/<case>.state (and the time to <case>.json), run on and save the outputs
      (ME: and the continuous states) to <case>.save.npy.
load: a fresh, only-instantiated instance (default parameters, never initialised)
      deserializes <case>.state, sets it, runs the same continuation from the saved time
      and saves <case>.load.npy, plus the selectors, parameters and inputs it reads back
      to <case>.load.json.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import fmi3_common as f3  # noqa: E402
import fmi4_common as fc  # noqa: E402

CS_WARMUP, CS_CONTINUE = 300, 1000
ME_WARMUP, ME_CONTINUE = 80, 160          # 10 ms segments
SEED = 20240611


def cs_sequence():
    """The standstill push and reversal, then fmi4_common.input_sequence's values held
    over each step: CS_WARMUP + CS_CONTINUE steps."""
    standstill = f3.standstill_reversal()
    n = CS_WARMUP + CS_CONTINUE - len(standstill["h"])
    return f3.concatenate(standstill, f3.piecewise_sequence(n, SEED))


def me_inputs():
    return f3.me_inputs(ME_WARMUP + ME_CONTINUE, SEED)


def params(law):
    return fc.STATE_PARAMS if law == "Unlimited" else {**fc.STATE_PARAMS, **fc.STATE_FRICTION_PARAMS}


def cases():
    return [(iface, model, law) for iface in ("cs", "me") for model, law in fc.STATE_CASES]


def case_name(iface, model, law):
    return f"{iface}-{model}-{law}"


def new_instance(md, unzipdir, iface, name):
    return f3.new_model3(md, unzipdir, name) if iface == "me" else f3.new_slave3(md, unzipdir, name)


def run(fmu, iface, t, start, stop):
    if iface == "cs":
        return f3.drive3(fmu, t, cs_sequence(), start, stop)
    return f3.EulerME(fmu).run(t, me_inputs(), start, stop)


def bounds(iface):
    warmup, more = (CS_WARMUP, CS_CONTINUE) if iface == "cs" else (ME_WARMUP, ME_CONTINUE)
    return warmup, warmup + more


def instances(role):
    """For every case, (instance, iface, model, law, case): a fresh, only-instantiated
    instance named <role>-<case>, from the FMU extracted once to a temporary folder. When
    the caller is done with it: no error logged, then the instance is freed."""
    md = f3.read_md3()
    with tempfile.TemporaryDirectory() as tmp:
        unzipdir = f3.extract_fmu3(tmp)
        for iface, model, law in cases():
            case = case_name(iface, model, law)
            s = new_instance(md, unzipdir, iface, f"{role}-{case}")
            yield s, iface, model, law, case
            assert not s.log.errors(), s.log.text()
            f3.close3(s)


def save(outdir: Path):
    for s, iface, model, law, case in instances("save"):
        warmup, end = bounds(iface)
        (f3.initialise_me3 if iface == "me" else f3.initialise3)(s, model, params(law), friction=law)
        _, t = run(s, iface, 0.0, 0, warmup)
        state = s.getFMUState()
        blob = s.serializeFMUState(state)
        s.freeFMUState(state)
        (outdir / f"{case}.state").write_bytes(blob)
        (outdir / f"{case}.json").write_text(json.dumps({"t": repr(t)}))
        Y, _ = run(s, iface, t, warmup, end)
        np.save(outdir / f"{case}.save.npy", Y)


def load(outdir: Path):
    for s, iface, model, law, case in instances("load"):
        warmup, end = bounds(iface)
        t = float(json.loads((outdir / f"{case}.json").read_text())["t"])
        state = s.deserializeFMUState((outdir / f"{case}.state").read_bytes())
        s.setFMUState(state)
        s.freeFMUState(state)
        readback = fc.configuration_readback(s.getInt64, s.getFloat64, fc.ALL_PARAMETER_VR)
        Y, _ = run(s, iface, t, warmup, end)
        np.save(outdir / f"{case}.load.npy", Y)
        (outdir / f"{case}.load.json").write_text(json.dumps(readback))


if __name__ == "__main__":
    mode, outdir = sys.argv[1], Path(sys.argv[2])
    {"save": save, "load": load}[mode](outdir)
