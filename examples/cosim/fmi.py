"""Either TireLag FMU through fmpy: FMI 2.0 (target/fmu/TireLag.fmu) or FMI 3.0
(target/fmu/fmi3/TireLag.fmu), told apart by the model description's fmiVersion.

The two FMUs have the same variables and value references (docs/specification.md 7c); fmpy gives them
different types and calls:

    FMI 2.0   Real, Integer      FMU2Slave  setReal, setInteger, setupExperiment
    FMI 3.0   Float64, Enum.     FMU3Slave  setFloat64, setInt64, enterInitializationMode(startTime)

``Slave`` is one Co-Simulation instance of either, with the calls the examples make.
What FMI 3.0 lacks is input derivatives (fmi2SetRealInputDerivatives): its Co-Simulation
holds every input constant over a step, so ``Slave.ramp_inputs`` exists for FMI 2.0 only
(``Slave.has_input_derivatives``); the examples hold each ramp's mean instead (``tire.py``).
"""

from __future__ import annotations

import ctypes
from pathlib import Path
from typing import Sequence

PROJECT = Path(__file__).resolve().parents[2]
FMU2_PATH = PROJECT / "target" / "fmu" / "TireLag.fmu"
FMU3_PATH = PROJECT / "target" / "fmu" / "fmi3" / "TireLag.fmu"
FMI2, FMI3 = "2.0", "3.0"
REAL_TYPES = ("Real", "Float64")              # FMI 2.0, FMI 3.0
SELECTOR_TYPES = ("Integer", "Enumeration")   # tireModel and friction in FMI 2.0, FMI 3.0


def fmi_version(model_description, path="the FMU") -> str:
    """FMI2 or FMI3 from the model description's fmiVersion; anything else is refused."""
    version = model_description.fmiVersion
    if version == "2.0":
        return FMI2
    if version.startswith("3."):
        return FMI3
    raise ValueError(f"{path} is an FMI {version} FMU; TireLag comes as FMI 2.0 ({FMU2_PATH}) "
                     f"or FMI 3.0 ({FMU3_PATH})")


def start_values(model_description) -> dict[str, float]:
    """Start values of the Real and selector variables (parameters and inputs), by name."""
    return {v.name: float(v.start) for v in model_description.modelVariables
            if v.start is not None and v.type in REAL_TYPES + SELECTOR_TYPES}


class Slave:
    """One initialisable Co-Simulation instance of either TireLag FMU.

    Calls by value reference, as fmpy's: set_real/get_real (Real, Float64), set_selector
    (the Integer/Enumeration tireModel and friction), set_string (tirFile), initialize
    (start time, enter and exit initialisation), do_step, ramp_inputs (FMI 2.0 only),
    save_state/restore_state (one FMU state slot), close. The *_array methods take ctypes
    arrays made once, for the per-step calls of a co-simulation master.
    """

    def __init__(self, model_description, unzipdir: str, instance_name: str, path="the FMU"):
        self.fmi_version = fmi_version(model_description, path)
        self.has_input_derivatives = self.fmi_version == FMI2
        md = model_description
        common = dict(guid=md.guid, unzipDirectory=unzipdir,
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=instance_name)
        if self.fmi_version == FMI3:
            from fmpy.fmi3 import FMU3Slave, fmi3Boolean, fmi3FMUState, fmi3Float64

            fmu = FMU3Slave(**common)
            fmu.instantiate()
            self.set_real, self.get_real, self.set_selector = fmu.setFloat64, fmu.getFloat64, fmu.setInt64
            self._state = fmi3FMUState()
            # fmi3DoStep's out-arguments, made once
            self._step_flags = [fmi3Boolean() for _ in range(3)]
            self._last_time = fmi3Float64()
            self._step_refs = [ctypes.byref(flag) for flag in self._step_flags] + [ctypes.byref(self._last_time)]
        else:
            from fmpy.fmi2 import FMU2Slave, fmi2FMUstate

            fmu = FMU2Slave(**common)
            fmu.instantiate()
            self.set_real, self.get_real, self.set_selector = fmu.setReal, fmu.getReal, fmu.setInteger
            self._state = fmi2FMUstate()
        self.fmu = fmu
        self.instance = fmu.component
        self.set_string = fmu.setString
        self._alive = True
        self._has_state = False

    # ---------------------------------------------------------------- setup
    def initialize(self, start_time: float = 0.0, stop_time: float | None = None) -> None:
        """After the parameters are set: the start time, then enter and exit initialisation."""
        if self.fmi_version == FMI3:
            self.fmu.enterInitializationMode(startTime=start_time, stopTime=stop_time)
        else:
            self.fmu.setupExperiment(startTime=start_time, stopTime=stop_time)
            self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    # ---------------------------------------------------------------- stepping
    def _require_input_derivatives(self) -> None:
        if not self.has_input_derivatives:
            raise TypeError(f"FMI {self.fmi_version} Co-Simulation has no input derivatives: hold "
                            f"the inputs over the step, or use the FMI 2.0 FMU ({FMU2_PATH})")

    def ramp_inputs(self, value_references: Sequence[int], rates: Sequence[float]) -> None:
        """First derivatives of Real inputs for the next step (fmi2SetRealInputDerivatives)."""
        self._require_input_derivatives()
        self.fmu.setRealInputDerivatives(list(value_references), [1] * len(value_references), list(rates))

    def do_step(self, time: float, step: float) -> None:
        if self.fmi_version == FMI3:
            self.fmu.fmi3DoStep(self.instance, time, step, True, *self._step_refs)
            # Every TireLag step completes (hasEventMode="false", no early return), so the
            # flags only confirm it.
            if any(flag.value for flag in self._step_flags[:2]):
                raise RuntimeError(f"fmi3DoStep at t = {time}: event handling or termination asked for, "
                                   "which TireLag never does")
        else:
            self.fmu.fmi2DoStep(self.instance, time, step, 1)

    def set_real_array(self, refs, n: int, values) -> None:
        if self.fmi_version == FMI3:
            self.fmu.fmi3SetFloat64(self.instance, refs, n, values, n)
        else:
            self.fmu.fmi2SetReal(self.instance, refs, n, values)

    def get_real_array(self, refs, n: int, values) -> None:
        if self.fmi_version == FMI3:
            self.fmu.fmi3GetFloat64(self.instance, refs, n, values, n)
        else:
            self.fmu.fmi2GetReal(self.instance, refs, n, values)

    def ramp_inputs_array(self, refs, n: int, orders, rates) -> None:
        """ramp_inputs with ctypes arrays (orders: c_int32 ones)."""
        self._require_input_derivatives()
        self.fmu.fmi2SetRealInputDerivatives(self.instance, refs, n, orders, rates)

    # ---------------------------------------------------------------- FMU state
    def save_state(self) -> None:
        """Into the one state slot (an FMU state made once, overwritten by later saves)."""
        if self.fmi_version == FMI3:
            self.fmu.fmi3GetFMUState(self.instance, ctypes.byref(self._state))
        else:
            self.fmu.fmi2GetFMUstate(self.instance, ctypes.byref(self._state))
        self._has_state = True

    def restore_state(self) -> None:
        if self.fmi_version == FMI3:
            self.fmu.fmi3SetFMUState(self.instance, self._state)
        else:
            self.fmu.fmi2SetFMUstate(self.instance, self._state)

    def close(self) -> None:
        """Frees the state slot and the instance (once; later calls do nothing)."""
        if not self._alive:
            return
        self._alive = False
        try:
            if self._has_state:
                if self.fmi_version == FMI3:
                    self.fmu.fmi3FreeFMUState(self.instance, ctypes.byref(self._state))
                else:
                    self.fmu.fmi2FreeFMUstate(self.instance, ctypes.byref(self._state))
            self.fmu.terminate()
        finally:
            self.fmu.freeInstance()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
