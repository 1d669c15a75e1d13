"""Independent reference for the friction limit of docs/specification.md 4c (stick and slide).

Written from docs/specification.md 3, 4, 4b, 4c and the friction semantics agreed for
the implementation (spelled out below), not from the Rust code; the only numbers taken
from the Rust source are the Brush branch fractions (src/physics/brush.rs BRUSH_BRANCHES,
derived by scripts/brush_fit.py).

Use: FrictionReferenceTire (the conftest.Tire interface: set, set_rates, step, outputs,
run) or simulate(model, friction, params, vx, U, h, Fz) (like reference.simulate).

The model
---------
Each model touches the road through contact elements (docs/specification.md 4c):

  model        lateral element (y)             longitudinal element (x)      yaw element
  RLT          spring C_y on uY                spring C_x on uX              -
  DDT          spring-damper C_y, dampingY     spring-damper C_x, dampingX   K = stiffnessPsi,
               on uY                           on uX                         D = dampingPsi on uPsi
  SecondOrder  tread spring kT_y on uT         spring C_x on uX              -
  RingBody     tread spring kT_y on uT         tread spring kT_x on uTx      -

Each element is split into parallel branches i (Coulomb: one branch w = phi = 1; Brush:
the four BRUSH_BRANCHES) with stiffness and damping fractions w_i and limit fractions
phi_i. Branch i has its own deflection b_i; the model's deflection state is the
stiffness-weighted sum U = sum w_i b_i. A sticking branch moves with the element's stick
rate evaluated at b_i,

    g_i = drive - (rho / sigma) b_i          (rho = |vx|, sigma the loaded length),

with drive = vy (RLT), vy + vx uPsi (DDT lateral), steerRate (DDT yaw), vsx (RLT, DDT,
SecondOrder longitudinal), w (lateral tread), wx (RingBody circumferential tread).

Branch i of the lateral element and branch i of the longitudinal element form a *planar
group*, bounded by the friction ellipse

    (F_x / (phi_i Fmax_x))^2 + (F_y / (phi_i Fmax_y))^2 <= 1;

branch i of DDT's yaw element is a scalar group, |M_i| <= phi_i M_max.

* Springs (F_k = w_i C_k b_k). Stick: db/dt = g. Slide (on the ellipse, force moving
  outward): associated flow db/dt = g - lambda n, n_k = F_k / L_k^2, L_k = phi_i Fmax_k,
  lambda = sum n_k w C_k g_k / sum n_k w C_k n_k, so the force stays on the ellipse; the
  group sticks again when lambda falls to 0. The right-hand side is discontinuous across
  the ellipse, so these groups carry a mode (stick/slide) and the integration stops at
  every switch (f(F) reaching 1 while sticking, lambda reaching 0 while sliding).
* Spring-dampers (DDT). Trial force T_k = w_i (C_k b_k + D_k g_k). Inside the ellipse:
  stick (F = T, db/dt = g). Outside: F_k = T_k / (1 + lam w_i D_k / L_k^2) with lam >= 0
  putting F on the ellipse, and db_k/dt = (F_k / w_i - C_k b_k) / D_k. The right-hand side
  is continuous (at the ellipse lam = 0 and both rules agree), so no mode is needed; the
  integration still stops where f(T) crosses 1 (a kink) to keep DOP853 at full order.
  Scalar yaw group: F = clamp(T, -phi_i M_max, phi_i M_max).

Limits (docs/specification.md 4c, Fz held over the step): mu(Fz) = mu max(0, 1 + muLoadSensitivity (Fz/Fz0 - 1)),
Fmax_x = muX(Fz) Fz, Fmax_y = muY(Fz) Fz, M_max = boreRadius muY(Fz) Fz.

Loads on the rest of the model are the branch sums (SecondOrder/RingBody: the contact
mass feels sum_i w_i kT b_i); the outputs are those of docs/specification.md 4 with the model's deflection
states replaced by U and, for DDT, the element forces by the (limited) branch forces F.
`Unlimited` is the linear model (one branch, no limit); it must agree with
reference.simulate, which this module's self-checks use.

Numerics: scipy's DOP853 stepper (rtol 1e-12) driven step by step. Every group has a switch
indicator (sticking spring group: f(F) - 1 - 1e-12; sliding: -lambda; damped kinks: the
signed distance of f(T) or |T| from the limit) whose rise through 0 is looked for at 16
points of the dense output of every DOP853 step (so a slide that starts and ends inside one
step is found too), located by brentq, and the integration restarted there with the new
mode; switches that coincide (the tread branches of a contact mass share its stick rate w,
so their lambdas change sign together) are made together, and after every switch the other
groups' modes are re-checked. Each piece is thus integrated on a smooth right-hand side.
A sliding spring group is put back exactly on its ellipse (radial scaling of its
deflections, a change of the order of the integration tolerance) at the end of every
piece. If Fz changes so that a spring group is outside its new limit, it is put on the
limit by the same radial scaling (docs/specification.md 4c: "its force is put on the limit"; a choice,
only exercised by test_matches_the_reference_with_a_varying_load). Accuracy: the FMU and
this reference agree to ~1e-12 of Fmax wherever the FMU finds every switch.

Not supported (not needed by the tests): lift-off (Fz <= 0), ramped vx or Fz, a DDT with
zero damping under friction.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import DOP853
from scipy.optimize import brentq

import reference as ref

# --------------------------------------------------------------------------- names

FRICTION_LAWS = {"Unlimited": 1, "Coulomb": 2, "Brush": 3}
FRICTION_NAMES = list(FRICTION_LAWS)
FRICTION_VR = 121
FRICTION_PARAMETER_VR = {"muX": 122, "muY": 123, "muLoadSensitivity": 124, "boreRadius": 125}
FRICTION_DEFAULTS = {"muX": 0.8, "muY": 0.8, "muLoadSensitivity": -0.1, "boreRadius": 0.1}
FRICTION_DEFAULT_LAW = "Brush"   # the FMU's start value (docs/specification.md 3)

# (w_i, phi_i) copied from src/physics/brush.rs BRUSH_BRANCHES (breakpoints phi/w =
# 0.2, 0.787, 1.454, 2.320; both columns sum to 1).
BRUSH_BRANCHES = (
    (0.30107885307910187, 0.060215770615820376),
    (0.3022951964290448, 0.23784454409059574),
    (0.2520860011716441, 0.36658544854155134),
    (0.1445399493202093, 0.3353542367520326),
)
COULOMB_BRANCHES = ((1.0, 1.0),)
UNLIMITED_BRANCHES = ((1.0, math.inf),)
BRANCHES = {"Unlimited": UNLIMITED_BRANCHES, "Coulomb": COULOMB_BRANCHES, "Brush": BRUSH_BRANCHES}

RTOL = 1e-12
ATOL = 1e-16          # states are of order 1e-6 .. 10 (m, rad, m/s); rtol governs
ON_LIMIT = 1e-12      # |f - 1| below which a spring group counts as on its ellipse


def parameters(**overrides) -> dict:
    """reference.parameters() plus the friction parameters (muX, muY, muLoadSensitivity,
    boreRadius), all as floats."""
    base = {k: v for k, v in overrides.items() if k not in FRICTION_DEFAULTS}
    p = ref.parameters(**base)
    p.update(FRICTION_DEFAULTS)
    for k, v in overrides.items():
        if k in FRICTION_DEFAULTS:
            p[k] = float(v)
    return p


# --------------------------------------------------------------------------- limits

def mu_at(p: dict, mu: float, Fz: float) -> float:
    """docs/specification.md 4c: mu(Fz) = mu max(0, 1 + muLoadSensitivity (Fz/Fz0 - 1))."""
    return mu * max(0.0, 1.0 + p["muLoadSensitivity"] * (Fz / p["Fz0"] - 1.0))


def limits(p: dict, Fz: float) -> dict:
    """Fmax_x, Fmax_y (N) and the DDT yaw limit M_max (N.m) at the normal load Fz."""
    Fz = float(Fz)
    muy = mu_at(p, p["muY"], Fz)
    return {"x": mu_at(p, p["muX"], Fz) * Fz, "y": muy * Fz, "psi": p["boreRadius"] * muy * Fz}


def brush_curve(x):
    """The brush model's steady force / Fmax, 3t - 3t^2 + t^3, t = min(1, |x|/3), odd in x;
    x = Calpha(Fz) alpha / Fmax."""
    x = np.asarray(x, float)
    t = np.minimum(1.0, np.abs(x) / 3.0)
    return np.sign(x) * (3.0 * t - 3.0 * t * t + t ** 3)


def steady_force_fraction(x, law="Brush"):
    """Steady rolling force / Fmax of a branched element at x = C(Fz) slip / Fmax:
    sum_i min(w_i |x|, phi_i), odd in x (Coulomb: min(|x|, 1); Unlimited: x)."""
    x = np.asarray(x, float)
    total = sum(np.minimum(w * np.abs(x), phi) for w, phi in BRANCHES[law])
    return np.sign(x) * total


# --------------------------------------------------------------------------- friction pieces
#
# Each function works on numpy arrays of any (matching) shape: one entry per branch and
# per time point. "k" is a branch stiffness w_i C, "d" a branch damping w_i D, "L" a branch
# limit phi_i Fmax.

def ellipse_value(Fy, Fx, Ly, Lx):
    """f = (Fy/Ly)^2 + (Fx/Lx)^2: 1 on the friction ellipse."""
    return (Fy / Ly) ** 2 + (Fx / Lx) ** 2


def spring_slide_multiplier(Fy, Fx, Ly, Lx, ky, kx, gy, gx):
    """lambda of the associated flow of a sliding spring group: n = F/L^2,
    lambda = sum n k g / sum n k n. lambda > 0: the motion pushes the force outward (the
    group slides); lambda <= 0: it would move inward (the group sticks)."""
    ny, nx = Fy / Ly ** 2, Fx / Lx ** 2
    with np.errstate(invalid="ignore", divide="ignore"):   # 0/0 for unloaded groups: unused
        lam = (ny * ky * gy + nx * kx * gx) / (ny * ky * ny + nx * kx * nx)
    return lam, ny, nx


def spring_slide_rates(Fy, Fx, Ly, Lx, ky, kx, gy, gx):
    """db/dt of a sliding spring group: g - lambda n, which keeps the force on the ellipse
    (d/dt sum (F/L)^2 = 2 sum n k (g - lambda n) = 0)."""
    lam, ny, nx = spring_slide_multiplier(Fy, Fx, Ly, Lx, ky, kx, gy, gx)
    return gy - lam * ny, gx - lam * nx


def damped_group_force(Ty, Tx, Ly, Lx, dy, dx):
    """Force (Fy, Fx) of one damped planar group (floats) from its trial force
    T = k b + d g: T inside the ellipse; outside, F = T / (1 + lam d / L^2) with lam >= 0
    putting F on the ellipse (slip rate lam F/L^2 along the normal; the damper in series
    takes d times it off T).

    The equation qy/(1 + lam ay)^2 + qx/(1 + lam ax)^2 = 1 (q = (T/L)^2, a = d/L^2) is convex
    and decreasing in lam; Newton from the lower bound (sqrt(f) - 1)/max(a) converges
    monotonically."""
    qy, qx = (Ty / Ly) ** 2, (Tx / Lx) ** 2
    f = qy + qx
    if not f > 1.0:
        return Ty, Tx
    ay, ax = dy / Ly ** 2, dx / Lx ** 2
    lam = (math.sqrt(f) - 1.0) / max(ay, ax)
    for _ in range(100):
        sy, sx = 1.0 / (1.0 + lam * ay), 1.0 / (1.0 + lam * ax)
        h = qy * sy * sy + qx * sx * sx - 1.0
        step = h / (2.0 * (qy * ay * sy ** 3 + qx * ax * sx ** 3))
        lam += step
        if abs(step) <= 4e-16 * lam or abs(h) <= 1e-15:
            break
    return Ty / (1.0 + lam * ay), Tx / (1.0 + lam * ax)


def damped_group_forces(Ty, Tx, Ly, Lx, dy, dx):
    """damped_group_force element by element over broadcast arrays."""
    Ty, Tx = np.array(Ty, float), np.array(Tx, float)
    out = np.nonzero(ellipse_value(Ty, Tx, Ly, Lx) > 1.0)
    if out[0].size == 0:
        return Ty, Tx
    Fy, Fx = Ty.copy(), Tx.copy()
    shape = Ty.shape
    Ly, Lx, dy, dx = (np.broadcast_to(a, shape) for a in (Ly, Lx, dy, dx))
    for idx in zip(*out):
        Fy[idx], Fx[idx] = damped_group_force(float(Ty[idx]), float(Tx[idx]), float(Ly[idx]),
                                              float(Lx[idx]), float(dy[idx]), float(dx[idx]))
    return Fy, Fx


def clamp_moments(T, L):
    """Scalar damped groups (DDT yaw): F = clamp(T, -L, L)."""
    return np.clip(T, -L, L)


def damped_rates(F, k, d, b):
    """db/dt of a damped branch carrying the force F: (F - k b)/d, i.e. (F/w - C b)/D;
    equal to the stick rate g while F = T."""
    return (F - k * b) / d


# --------------------------------------------------------------------------- the tire

EPS_F = 1e-12     # a sticking spring group starts sliding at f = 1 + EPS_F (then put on f = 1)
GRID = 16         # sign checks of the switch indicators per DOP853 step (dense output)
SIMULTANEOUS = 1e-12   # switches closer than this fraction of the step piece are one event


class FrictionReferenceTire:
    """The friction reference behind the conftest.Tire interface (set, set_rates, step,
    outputs, get, run), so harness.wheel_cosim can drive it.

    State z = [non-element states, lateral branches b_y (nb), longitudinal b_x (nb),
    yaw b_psi (nb, DDT only)], non-element states SecondOrder [eta, w], RingBody
    [eta, w, xr, wx]. vy, steerRate and vsx may be ramped with set_rates; vx and Fz are held.

    Switches are found by the sign of one indicator per group, evaluated on the dense
    output of every DOP853 step at GRID points, and located by brentq; the integration is
    restarted there with the new mode.
    """

    def __init__(self, model="DDT", friction="Brush", params=None, vx=0.0, vy=0.0,
                 steerRate=0.0, vsx=0.0, Fz=None):
        if model not in ref.MODELS:
            raise ValueError(model)
        self.model = model
        self.friction = friction
        self.limited = friction != "Unlimited"
        branches = np.array(BRANCHES[friction], float)
        self.w = branches[:, 0:1]            # column vectors: broadcast over time points
        self.phi = branches[:, 1:2]
        nb = len(branches)
        self.nb = nb
        self.p = p = parameters(**(params or {}))
        self.q = q = ref.derived(p)
        self.inputs = {"vx": float(vx), "vy": float(vy), "steerRate": float(steerRate),
                       "vsx": float(vsx), "Fz": float(p["Fz0"] if Fz is None else Fz)}
        self.rates = {k: 0.0 for k in ref.DRIVING}
        self.t = 0.0
        self.n_events = 0            # switches met so far (stick/slide; kinks for DDT)
        self.others = {"RLT": [], "DDT": [], "SecondOrder": ["eta", "w"],
                       "RingBody": ["eta", "w", "xr", "wx"]}[model]
        self.io = {name: i for i, name in enumerate(self.others)}
        # contact mass, carcass damping, k_y; RingBody's m_x, k_x, ringDampingX
        self._contact = ((p["contactMass"], p["carcassDampingY"]) if model == "SecondOrder"
                         else (p["ringMass"], p["ringDampingY"])) + (
            q["k_y"], p["ringInertia"] / p["Re"] ** 2, q["k_x"], p["ringDampingX"])
        C = {"RLT": {"y": q["C_y"], "x": q["C_x"]},
             "DDT": {"y": q["C_y"], "x": q["C_x"], "psi": p["stiffnessPsi"]},
             "SecondOrder": {"y": q["kT_y"], "x": q["C_x"]},
             "RingBody": {"y": q["kT_y"], "x": q["kT_x"]}}[model]
        D = {"y": p["dampingY"], "x": p["dampingX"], "psi": p["dampingPsi"]}
        self.damped = model == "DDT"
        start = len(self.others)
        self.sl, self.k, self.d = {}, {}, {}
        for direction in C:
            self.sl[direction] = slice(start, start + nb)
            start += nb
            self.k[direction] = self.w * C[direction]                         # w_i C
            self.d[direction] = self.w * D[direction] if self.damped else None  # w_i D
        self.w1 = self.w[:, 0]                                  # flat copies for _rhs
        self.k1 = {e: v[:, 0] for e, v in self.k.items()}
        self.d1 = {e: None if v is None else v[:, 0] for e, v in self.d.items()}
        if self.damped and self.limited and min(D.values()) <= 0.0:
            raise NotImplementedError("DDT with zero damping under friction")
        self.z = np.zeros(start)
        self.slide = np.zeros(nb, bool)      # modes of the spring groups
        self.outside = np.zeros(nb, bool)    # damped planar groups: trial force outside
        self.yaw_side = np.zeros(nb, int)    # damped yaw groups: -1, 0 (inside), +1
        self._tau = 0.0                      # time into the current step
        self._setup()

    # ---------------------------------------------------------------- per-step constants
    def _setup(self):
        p = self.p
        Fz = self.inputs["Fz"]
        if not Fz > 0.0:
            raise NotImplementedError("lift-off is not modelled by the friction reference")
        rho = abs(self.inputs["vx"])
        f_lat, f_long = ref.length_factors(p, Fz)
        self.sigma_y, self.sigma_x = p["sigmaY"] * f_lat, p["sigmaX"] * f_long
        lengths = {"RLT": {"y": self.sigma_y, "x": self.sigma_x},
                   "DDT": {"y": self.sigma_y, "x": self.sigma_x, "psi": p["sigmaPsi"] * f_lat},
                   "SecondOrder": {"y": p["sigmaTread"] * f_lat, "x": self.sigma_x},
                   "RingBody": {"y": p["sigmaTread"] * f_lat, "x": p["sigmaTread"] * f_long}}
        self.relax = {d: rho / s for d, s in lengths[self.model].items()}
        lim = limits(p, Fz)
        self.L = {d: self.phi * lim[d] for d in ("y", "x", "psi")}
        self.L1 = {d: v[:, 0] for d, v in self.L.items()}      # flat copies for _rhs
        self._key = (self.inputs["vx"], Fz)

    # ---------------------------------------------------------------- inputs
    def set(self, **inputs):
        for k, v in inputs.items():
            self.inputs[k] = float(v)

    def set_rates(self, **rates):
        for k, v in rates.items():
            if k not in self.rates:
                raise NotImplementedError(f"ramped {k}")
            self.rates[k] = float(v)

    def _u(self, tau):
        """Driving inputs (vy, steerRate, vsx) at time(s) tau into the current step."""
        i, r = self.inputs, self.rates
        return (i["vy"] + r["vy"] * tau, i["steerRate"] + r["steerRate"] * tau,
                i["vsx"] + r["vsx"] * tau)

    # ---------------------------------------------------------------- element kinematics
    # Z has shape (n_states, m): m time points at once.
    def _U(self, Z, d):
        """The model's deflection state sum_i w_i b_i of element d."""
        return np.sum(self.w * Z[self.sl[d]], axis=0)

    def _drives(self, Z, u):
        vy, r, vsx = u
        m = self.model
        if m == "RLT":
            return {"y": vy, "x": vsx}
        if m == "DDT":
            return {"y": vy + self.inputs["vx"] * self._U(Z, "psi"), "x": vsx, "psi": r}
        if m == "SecondOrder":
            return {"y": Z[self.io["w"]], "x": vsx}
        return {"y": Z[self.io["w"]], "x": Z[self.io["wx"]]}

    def _stick_rates(self, Z, u):
        """g[d] = drive_d - (rho/sigma_d) b_i, shape (nb, m)."""
        drive = self._drives(Z, u)
        return {d: np.asarray(drive[d]) - self.relax[d] * Z[s] for d, s in self.sl.items()}

    def _trial_forces(self, Z, g):
        """Branch forces without the limit: k b (+ d g for the damped elements)."""
        T = {d: self.k[d] * Z[s] for d, s in self.sl.items()}
        if self.damped:
            for d in T:
                T[d] = T[d] + self.d[d] * g[d]
        return T

    def _forces(self, Z, u):
        """Branch forces {d: (nb, m)}: springs k b (their sliders hold b); damped elements
        the trial force limited by damped_group_forces / clamp_moments."""
        g = self._stick_rates(Z, u)
        F = self._trial_forces(Z, g)
        if self.damped and self.limited:
            F["y"], F["x"] = damped_group_forces(F["y"], F["x"], self.L["y"], self.L["x"],
                                                 self.d["y"], self.d["x"])
            F["psi"] = clamp_moments(F["psi"], self.L["psi"])
        return F, g

    # ---------------------------------------------------------------- right-hand side
    def _rhs(self, tau, z):
        """dz/dt in the current modes (the branch dimension flattened: faster than the
        (n, m) forms used for the indicators and outputs, same equations)."""
        vy, r, vsx = self._u(tau)
        sy, sx = self.sl["y"], self.sl["x"]
        by, bx = z[sy], z[sx]
        dz = np.empty_like(z)
        if self.damped:
            bp = z[self.sl["psi"]]
            drive_y = vy + self.inputs["vx"] * float(self.w1 @ bp)
            g = {"y": drive_y - self.relax["y"] * by, "x": vsx - self.relax["x"] * bx,
                 "psi": r - self.relax["psi"] * bp}
            b = {"y": by, "x": bx, "psi": bp}
            k, d = self.k1, self.d1
            T = {e: k[e] * b[e] + d[e] * g[e] for e in b}
            if self.limited:
                T["y"], T["x"] = damped_group_forces(T["y"], T["x"], self.L1["y"], self.L1["x"],
                                                     d["y"], d["x"])
                T["psi"] = clamp_moments(T["psi"], self.L1["psi"])
            for e, sl in self.sl.items():
                dz[sl] = damped_rates(T[e], k[e], d[e], b[e])
            return dz
        if self.model == "RLT":
            drive_y, drive_x = vy, vsx
        elif self.model == "SecondOrder":
            drive_y, drive_x = z[1], vsx
        else:
            drive_y, drive_x = z[1], z[3]
        gy = drive_y - self.relax["y"] * by
        gx = drive_x - self.relax["x"] * bx
        Fy, Fx = self.k1["y"] * by, self.k1["x"] * bx
        if self.limited and self.slide.any():
            ry, rx = spring_slide_rates(Fy, Fx, self.L1["y"], self.L1["x"],
                                        self.k1["y"], self.k1["x"], gy, gx)
            gy, gx = np.where(self.slide, ry, gy), np.where(self.slide, rx, gx)
        dz[sy], dz[sx] = gy, gx
        if self.others:
            self._contact_mass_rates(z, (vy, r, vsx), {"y": Fy, "x": Fx}, dz)
        return dz

    def _contact_mass_rates(self, Z, u, F, dZ):
        """docs/specification.md 4 contact-mass equations, the tread force being sum_i F_i:
        deta/dt = w - vy, m dw/dt = -F_tread - k_y eta - d (w - vy); RingBody also
        dxr/dt = wx - vsx, m_x dwx/dt = -F_tread,x - k_x xr - ringDampingX (wx - vsx)."""
        vy, _, vsx = u
        mass, damping, k_y, mx, k_x, dx = self._contact
        eta, w = Z[0], Z[1]
        dZ[0] = w - vy
        dZ[1] = (-F["y"].sum(axis=0) - k_y * eta - damping * (w - vy)) / mass
        if self.model == "RingBody":
            xr, wx = Z[2], Z[3]
            dZ[2] = wx - vsx
            dZ[3] = (-F["x"].sum(axis=0) - k_x * xr - dx * (wx - vsx)) / mx

    # ---------------------------------------------------------------- switches
    def _indicators(self, tau, Z):
        """One switch indicator per group, shape (n_groups, m); a switch happens where one
        rises through 0.
        Spring group i: sticking f(F) - 1 - EPS_F, sliding -lambda.
        Damped (DDT): planar group i: +-(f(T) - 1) (sign: side of the kink); yaw group i:
        |T| - L inside, L - side T outside."""
        u = self._u(tau)
        g = self._stick_rates(Z, u)
        T = self._trial_forces(Z, g)
        f = ellipse_value(T["y"], T["x"], self.L["y"], self.L["x"])
        if self.damped:
            planar = np.where(self.outside[:, None], 1.0 - f, f - 1.0)
            side = self.yaw_side[:, None]
            L = self.L["psi"]
            yaw = np.where(side == 0, np.abs(T["psi"]) - L, L - side * T["psi"])
            return np.vstack([planar, yaw])
        lam, _, _ = spring_slide_multiplier(T["y"], T["x"], self.L["y"], self.L["x"],
                                            self.k["y"], self.k["x"], g["y"], g["x"])
        return np.where(self.slide[:, None], -lam, f - 1.0 - EPS_F)

    def _switch(self, k, tau):
        """Group k's indicator rose through 0 at tau: change its mode / side."""
        nb = self.nb
        if not self.damped:
            self.slide[k] = not self.slide[k]
            if self.slide[k]:
                self._put_on_ellipse(k)
        elif k < nb:
            self.outside[k] = not self.outside[k]
        else:
            i = k - nb
            if self.yaw_side[i] == 0:
                Z = self.z[:, None]
                T = self._trial_forces(Z, self._stick_rates(Z, self._u(tau)))
                self.yaw_side[i] = 1 if T["psi"][i, 0] > 0.0 else -1
            else:
                self.yaw_side[i] = 0

    def _put_on_ellipse(self, i):
        """Radially scale spring group i's deflections so that f(F) = 1 exactly."""
        z = self.z
        by, bx = z[self.sl["y"]], z[self.sl["x"]]
        f = ellipse_value(self.k["y"][i, 0] * by[i], self.k["x"][i, 0] * bx[i],
                          self.L["y"][i, 0], self.L["x"][i, 0])
        s = 1.0 / math.sqrt(f)
        z[self.sl["y"].start + i] *= s
        z[self.sl["x"].start + i] *= s

    def _decide_modes(self, exempt=()):
        """At the start of a step (new inputs) and after every switch (for the groups that
        did not just switch, `exempt`). Spring groups: outside -> put on the limit; on the
        ellipse -> slide iff the motion pushes outward (lambda > 0); else stick. Damped
        groups: record on which side of each kink the trial force is."""
        if not self.limited:
            return
        nb = self.nb
        Z = self.z[:, None]
        u = self._u(self._tau)
        g = self._stick_rates(Z, u)
        T = self._trial_forces(Z, g)
        f = ellipse_value(T["y"], T["x"], self.L["y"], self.L["x"])[:, 0]
        if self.damped:
            t, L = T["psi"][:, 0], self.L["psi"][:, 0]
            for i in range(nb):
                if i not in exempt:
                    self.outside[i] = f[i] > 1.0
                if nb + i not in exempt:
                    self.yaw_side[i] = 1 if t[i] > L[i] else (-1 if t[i] < -L[i] else 0)
            return
        for i in range(nb):
            if i not in exempt and f[i] > 1.0 + EPS_F:
                self._put_on_ellipse(i)
        Z = self.z[:, None]
        g = self._stick_rates(Z, u)
        T = self._trial_forces(Z, g)
        f = ellipse_value(T["y"], T["x"], self.L["y"], self.L["x"])[:, 0]
        lam, _, _ = spring_slide_multiplier(T["y"], T["x"], self.L["y"], self.L["x"],
                                            self.k["y"], self.k["x"], g["y"], g["x"])
        for i in range(nb):
            if i not in exempt:
                self.slide[i] = f[i] >= 1.0 - ON_LIMIT and lam[i, 0] > 0.0

    # ---------------------------------------------------------------- stepping
    def _integrate(self, tau0, h):
        """Integrate from tau0 towards h in the current modes; stop at the first switch.
        Returns (tau reached, indices of the switching groups: [] if none)."""
        solver = DOP853(self._rhs, tau0, self.z, h, rtol=RTOL, atol=ATOL)
        prev = self._indicators(tau0, self.z[:, None])[:, 0] if self.limited else None
        while solver.status == "running":
            msg = solver.step()
            if solver.status == "failed":
                raise RuntimeError(msg)
            if not self.limited:
                continue
            dense = solver.dense_output()
            ts = np.linspace(solver.t_old, solver.t, GRID + 1)
            ts[0], ts[-1] = solver.t_old, solver.t
            ind = self._indicators(ts[1:], dense(ts[1:]))
            ind = np.column_stack([prev, ind])
            rises = (ind[:, :-1] <= 0.0) & (ind[:, 1:] > 0.0)
            if rises.any():
                c = int(np.nonzero(rises.any(axis=0))[0][0])
                roots = {}
                for k in np.nonzero(rises[:, c])[0]:
                    roots[int(k)] = brentq(
                        lambda t: self._indicators(t, dense(t)[:, None])[k, 0],
                        ts[c], ts[c + 1], xtol=1e-300, rtol=4 * np.finfo(float).eps)
                first = min(roots.values())
                # groups whose switch coincides (e.g. all tread branches of a contact mass
                # share the stick rate w, so their lambdas change sign together) switch together
                together = [k for k, t in roots.items() if t <= first + SIMULTANEOUS * (h - tau0)]
                self.z = dense(first).copy()
                return first, together
            prev = ind[:, -1]
        self.z = solver.y.copy()
        return h, []

    def step(self, h):
        """Advance by h with the inputs held (vy, steerRate, vsx ramped by their rates)."""
        if (self.inputs["vx"], self.inputs["Fz"]) != self._key:
            self._setup()
        tau, pieces = 0.0, 0
        self._tau = tau
        self._decide_modes()
        while tau < h:
            pieces += 1
            if pieces > 100000:
                raise RuntimeError("too many switches in one step")
            tau, switching = self._integrate(tau, h)
            self._tau = tau
            for k in switching:
                self.n_events += 1
                self._switch(k, tau)
            if switching:
                self._decide_modes(exempt=switching)
            if not self.damped:
                for i in np.nonzero(self.slide)[0]:
                    self._put_on_ellipse(i)
        for k in ref.DRIVING:
            self.inputs[k] += h * self.rates[k]
        self.t += h

    # ---------------------------------------------------------------- outputs
    def branch_forces(self):
        """Branch forces {direction: array (nb,)} at the current state and inputs."""
        if (self.inputs["vx"], self.inputs["Fz"]) != self._key:
            self._setup()
        F, _ = self._forces(self.z[:, None], self._u(0.0))
        return {d: v[:, 0] for d, v in F.items()}

    def ellipse_values(self):
        """(F_y,i/L_y,i)^2 + (F_x,i/L_x,i)^2 of every planar group (never above 1)."""
        F = self.branch_forces()
        return ellipse_value(F["y"], F["x"], self.L["y"][:, 0], self.L["x"][:, 0])

    def outputs(self):
        """All nine outputs (reference.OUTPUTS order) at the current state and inputs."""
        if (self.inputs["vx"], self.inputs["Fz"]) != self._key:
            self._setup()
        z = self.z
        p, q, io = self.p, self.q, self.io
        vy, _, vsx = self._u(0.0)
        F = self.branch_forces()
        Z = z[:, None]
        defl_y, defl_x = self._U(Z, "y")[0], self._U(Z, "x")[0]
        defl_psi, yaw, my = 0.0, 0.0, None
        fx = -F["x"].sum()
        if self.model in ("RLT", "DDT"):
            fy = -F["y"].sum()
            if self.model == "DDT":
                yaw = -F["psi"].sum()
                defl_psi = self._U(Z, "psi")[0]
        else:
            damping = p["carcassDampingY"] if self.model == "SecondOrder" else p["ringDampingY"]
            eta, w = z[io["eta"]], z[io["w"]]
            fy = q["k_y"] * eta + damping * (w - vy)
            defl_y -= eta
            if self.model == "RingBody":
                xr, wx = z[io["xr"]], z[io["wx"]]
                my = -p["Re"] * (q["k_x"] * xr + p["ringDampingX"] * (wx - vsx))
                defl_x -= xr
        if my is None:
            my = -p["Re"] * fx
        y = {"Fx": fx, "Fy": fy, "Mz": yaw - p["trail"] * fy, "My": my,
             "alphaT": -defl_y / self.sigma_y, "kappaT": -defl_x / self.sigma_x,
             "deflX": defl_x, "deflY": defl_y, "deflPsi": defl_psi}
        return np.array([y[o] for o in ref.OUTPUTS], float)

    def get(self, *names):
        y = self.outputs()
        return np.array([y[ref.OUT[n]] for n in names])

    def run(self, U, h, dU=None, vx=None, Fz=None):
        """Same contract as conftest.Tire.run: (N, 9) outputs at the end of each step."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        N = U.shape[0]
        hs = np.broadcast_to(np.asarray(h, dtype=float), (N,))
        Y = np.empty((N, len(ref.OUTPUTS)))
        for k in range(N):
            if vx is not None:
                self.set(vx=np.broadcast_to(vx, (N,))[k])
            if Fz is not None:
                self.set(Fz=np.broadcast_to(Fz, (N,))[k])
            self.set(**dict(zip(ref.DRIVING, U[k])))
            if dU is not None:
                self.set_rates(**dict(zip(ref.DRIVING, dU[k])))
            self.step(float(hs[k]))
            Y[k] = self.outputs()
        return Y

    def close(self):
        pass


def simulate(model, friction, p=None, vx=0.0, U=None, h=0.01, Fz=None, dU=None):
    """Outputs at the end of each step, like reference.simulate: vx, Fz scalars or one value
    per step (held), U (N, 3) [vy, steerRate, vsx] held (or ramped with dU) over each step.
    p: overrides of the default parameters (friction ones included)."""
    U = np.atleast_2d(np.asarray(U, dtype=float))
    N = U.shape[0]
    vxs = np.broadcast_to(np.asarray(vx, dtype=float), (N,))
    fz0 = None if Fz is None else float(np.broadcast_to(Fz, (N,))[0])
    tire = FrictionReferenceTire(model, friction, params=p, vx=vxs[0], Fz=fz0)
    return tire.run(U, h, dU=dU, vx=vxs, Fz=Fz)
