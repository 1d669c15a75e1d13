"""A small co-simulation layer for the TireLag examples.

fmi.py        either TireLag FMU, FMI 2.0 or FMI 3.0: one Co-Simulation instance (fmi.Slave)
tire.py       the TireLag FMU as a tire block (one fmi.Slave each, the FMU extracted once per
              process), and a tire without lag
coupling.py   the master: a linear vehicle body stepped exactly, coupled implicitly to the
              tires with ramped inputs (fmi2SetRealInputDerivatives; FMI 3.0: their means)
vehicle.py    a single-track vehicle (and Koo & Tan's snowblower on it)
frequency.py  multisine excitation, frequency responses, rational fits, modes (and ERA)
cli.py        the command line and output files the example scripts share
"""

from .coupling import CoSimulation, CouplingError, Trajectory, first_order_hold
from .frequency import (Mode, Multisine, RationalFit, era_poles, fit_rational, frequency_response,
                        log_harmonics, oscillatory_modes, steps_per_period)
from .tire import (TIRE_MODELS, FMUFile, SteadyStateTire, TireLag, default_fmu_path, extraction_count,
                   load_fmu)
from .vehicle import (SNOWBLOWER_BODY, SNOWBLOWER_CONTACT_YAW, SNOWBLOWER_TIRE, SNOWBLOWER_VARIANTS,
                      Bicycle, BicycleParameters, ContactYawCompliance, snowblower)
