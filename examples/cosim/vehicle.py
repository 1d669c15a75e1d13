"""Vehicle models for the co-simulation master: a single-track (bicycle) body on TireLag tires.

Frames and signs (ISO 8855, docs/specification.md 2): x forward, y to the left, z up; yaw and
steer angles are positive counter-clockwise seen from above (to the left). Small angles
throughout, as in the papers: the vehicle moves forward at a constant speed U, and its
lateral and yaw motion is linear.

Body states (SI units):
    v   lateral velocity of the centre of gravity in the body frame [m/s]
    r   yaw rate [rad/s]
External inputs:
    steer        steer angle of the front wheels relative to the body [rad]
    yaw_moment   a disturbance yaw moment on the body [N.m]
    side_force   a disturbance lateral force on the body at the centre of gravity [N]

Each axle is one TireLag instance standing for the ``tires_per_axle`` identical tires of
that axle (in a bicycle model both tires of an axle see the same motion), so the axle
force is tires_per_axle * Fy. The tire inputs, in each wheel's frame:

    front: vx = U, vy = v + a r - U (steer + chi), steerRate = d(steer)/dt
    rear:  vx = U, vy = v - b r - U chi

chi is the heading of the tire contact patches relative to the body. In a conventional
bicycle model the patches follow the body, chi = 0. Koo & Tan's improved model
(eqs 31-32, 38) ties the body to the contact patches by a yaw spring-damper k1, c1 (the
longitudinal compliance of the left and right tires): the contact-patch line then has its
own heading, chi = -(deflY_front - deflY_rear)/L, and the body feels
-k1 (psi_body - psi_contact) - c1 d/dt(...) with psi_body - psi_contact = -chi.

The body equations are
    M (dv/dt + U r) = n (Fy_f + Fy_r) + side_force
    Iz dr/dt        = n (a Fy_f - b Fy_r) + n (Mz_f + Mz_r) + yaw_moment + M_contact
where n = tires_per_axle and M_contact is the k1, c1 moment (0 without it). The front
Mz reaches the body through the steering (the steering inertia I2 is neglected, as in
Koo & Tan eq 35 with I2 = 0).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

from .coupling import TireBlock


@dataclass(frozen=True)
class BicycleParameters:
    mass: float              # M [kg]
    yaw_inertia: float       # Iz [kg.m2] (Koo & Tan's I1)
    front_distance: float    # a = l1: centre of gravity to front axle [m]
    rear_distance: float     # b = l2: centre of gravity to rear axle [m]
    tires_per_axle: int = 2

    @property
    def wheelbase(self) -> float:
        return self.front_distance + self.rear_distance


@dataclass(frozen=True)
class ContactYawCompliance:
    """Koo & Tan's yaw spring-damper between the body and the contact-patch line (eq 38)."""

    stiffness: float   # k1 [N.m/rad]
    damping: float     # c1 [N.m.s/rad]


class Bicycle:
    """A single-track vehicle at constant forward speed on two tire blocks (see module doc).

    front, rear: tire blocks with inputs ("vy", "steerRate") or ("vy",) and outputs
    including "Fy" and "Mz" (and "deflY" when ``contact_yaw`` is given).
    """

    state_names = ("v", "r")
    external_names = ("steer", "yaw_moment", "side_force")

    def __init__(self, params: BicycleParameters, speed: float, front: TireBlock, rear: TireBlock,
                 contact_yaw: ContactYawCompliance | None = None):
        self.p = params
        self.speed = float(speed)
        self.contact_yaw = contact_yaw
        self.tires = {"front": front, "rear": rear}
        need = {"Fy", "Mz"} | ({"deflY"} if contact_yaw else set())
        for corner, tire in self.tires.items():
            missing = need - set(tire.output_names)
            if missing:
                raise ValueError(f"{corner} tire must output {sorted(missing)}")

    def fixed_tire_inputs(self) -> Mapping[str, Mapping[str, float]]:
        return {"front": {"vx": self.speed}, "rear": {"vx": self.speed}}

    def _contact_heading(self, tire) -> float:
        """chi: heading of the contact-patch line relative to the body [rad]."""
        if self.contact_yaw is None:
            return 0.0
        return -(tire["front"]["deflY"] - tire["rear"]["deflY"]) / self.p.wheelbase

    def tire_inputs(self, x, tire, ext, ext_rate):
        U, a, b = self.speed, self.p.front_distance, self.p.rear_distance
        chi = self._contact_heading(tire)
        front = {"vy": x["v"] + a * x["r"] - U * (ext["steer"] + chi)}
        if "steerRate" in self.tires["front"].input_names:
            front["steerRate"] = ext_rate["steer"]
        return {"front": front, "rear": {"vy": x["v"] - b * x["r"] - U * chi}}

    def derivatives(self, x, tire, tire_rate, ext, ext_rate):
        p, U = self.p, self.speed
        n = p.tires_per_axle
        f, r = tire["front"], tire["rear"]
        side = n * (f["Fy"] + r["Fy"]) + ext["side_force"]
        yaw = (n * (p.front_distance * f["Fy"] - p.rear_distance * r["Fy"])
               + n * (f["Mz"] + r["Mz"]) + ext["yaw_moment"])
        if self.contact_yaw is not None:
            # psi_body - psi_contact = -chi; its rate from the deflection rates
            twist = -self._contact_heading(tire)
            twist_rate = -self._contact_heading(tire_rate)
            yaw -= self.contact_yaw.stiffness * twist + self.contact_yaw.damping * twist_rate
        return [side / p.mass - U * x["r"], yaw / p.yaw_inertia]

    def close(self) -> None:
        for tire in self.tires.values():
            tire.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ---------------------------------------------------------------- reference values
    def understeer_gradient(self, front_Calpha: float, rear_Calpha: float) -> float:
        """K [rad/(m/s^2)] of the steady-state yaw gain r/steer = U/(L + K U^2), from the
        axle cornering stiffnesses n*Calpha (Koo & Tan eq 48 from Appendix C; Kim eq 23)."""
        p = self.p
        n = p.tires_per_axle
        return p.mass / p.wheelbase * (p.rear_distance / (n * front_Calpha)
                                       - p.front_distance / (n * rear_Calpha))


# --------------------------------------------------------------------------- snowblower

# Koo & Tan 2007, Table 1: the identified snowblower (the vehicle, and each of its tires).
SNOWBLOWER_BODY = BicycleParameters(mass=20500.0, yaw_inertia=168250.0,
                                    front_distance=1.3, rear_distance=2.2, tires_per_axle=2)
SNOWBLOWER_CONTACT_YAW = ContactYawCompliance(stiffness=500000.0, damping=10000.0)
# Calpha and sigmaY give C_lat = Calpha/sigmaY = 350000 N/m (eq 16); stiffnessPsi = k2/2.
# Koo & Tan drop the yaw damping c2 = 2 D_yaw (after eq 39) and the trail from the vehicle
# model, so both are 0 here.
SNOWBLOWER_TIRE = {"Calpha": 350000.0, "sigmaY": 1.0, "sigmaPsi": 0.45, "dampingY": 9000.0,
                   "stiffnessPsi": 40000.0, "dampingPsi": 0.0, "trail": 0.0}
SNOWBLOWER_VARIANTS = {
    "DDT": "improved bicycle model: DDT tires, body-to-contact-patch yaw spring k1, c1 (Appendix A)",
    "RLT": "bicycle model with RLT tires (Appendix D)",
    "none": "plain bicycle model, no tire lag (Appendix C)",
}


# The parameters a tire property file maps (docs/specification.md 10).
MAPPED_BY_TIR_FILE = ("Fz0", "Calpha", "calphaLoadPeak", "Ckappa", "muX", "muY", "muLoadSensitivity",
                      "sigmaY", "sigmaX", "trail", "Re")


def snowblower(fmu, tire_model: str, speed: float, tire_parameters: Mapping[str, float] | None = None,
               contact_yaw: bool | None = None, tir_file=None) -> Bicycle:
    """Koo & Tan's snowblower as a Bicycle on TireLag instances (one per axle).

    tire_model: "DDT" (Koo & Tan's improved model), "RLT" (their bicycle model with RLT)
    or "none" (their plain bicycle model, a SteadyStateTire without lag; needs speed > 0).
    tire_parameters: overrides of SNOWBLOWER_TIRE (e.g. {"sigmaY": 0.8}).
    contact_yaw: the k1, c1 body-to-contact-patch spring; by default only with DDT, as in
    the paper (its RLT and plain models have none).
    tir_file: a tire property file for the FMU's tirFile: the values it maps come from it
    (unless tire_parameters sets them), the others from SNOWBLOWER_TIRE.
    """
    from .tire import SteadyStateTire, TireLag

    params = dict(SNOWBLOWER_TIRE, **(tire_parameters or {}))
    if tir_file is not None:
        params = {k: v for k, v in params.items()
                  if k not in MAPPED_BY_TIR_FILE or k in (tire_parameters or {})}
    if contact_yaw is None:
        contact_yaw = tire_model == "DDT"
    outputs = ("Fy", "Mz", "deflY")
    if tire_model == "none":
        front = SteadyStateTire(params["Calpha"], params["trail"], name="front", outputs=("Fy", "Mz"))
        rear = SteadyStateTire(params["Calpha"], params["trail"], name="rear", outputs=("Fy", "Mz"))
        if contact_yaw:
            raise ValueError("the plain bicycle model has no contact-patch deflection for k1, c1")
    else:
        # a linear analysis, as in the paper: no friction limit
        front = TireLag(fmu, tire_model, params, name="front", inputs=("vy", "steerRate"), outputs=outputs,
                        friction="Unlimited", tir_file=tir_file)
        rear = TireLag(fmu, tire_model, params, name="rear", inputs=("vy",), outputs=outputs,
                       friction="Unlimited", tir_file=tir_file)
    return Bicycle(SNOWBLOWER_BODY, speed, front, rear,
                   SNOWBLOWER_CONTACT_YAW if contact_yaw else None)
