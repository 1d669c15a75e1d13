"""Independent reference for the friction limit of SPEC section 4c (stick and slide).

Written from the SPEC text (sections 3, 4, 4b, 4c) and the friction semantics made precise
in the task brief; the only numbers taken from the Rust source are the Brush branch
fractions (src/physics/brush.rs BRUSH_BRANCHES, derived by scripts/brush_fit.py).

The model
---------
Each model touches the road through contact elements (SPEC 4c):

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
  every switch (events: f(F) = 1 while sticking, lambda = 0 while sliding).
* Spring-dampers (DDT). Trial force T_k = w_i (C_k b_k + D_k g_k). Inside the ellipse:
  stick (F = T, db/dt = g). Outside: F_k = T_k / (1 + lam w_i D_k / L_k^2) with lam >= 0
  putting F on the ellipse, and db_k/dt = (F_k / w_i - C_k b_k) / D_k. The right-hand side
  is continuous (at the ellipse lam = 0 and both rules agree), so no mode is needed; the
  integration still stops where f(T) crosses 1 (a kink) to keep DOP853 at full order.
  Scalar yaw group: F = clamp(T, -phi_i M_max, phi_i M_max).

Limits (SPEC 4c, Fz held over the step): mu(Fz) = mu max(0, 1 + muLoadSensitivity (Fz/Fz0 - 1)),
Fmax_x = muX(Fz) Fz, Fmax_y = muY(Fz) Fz, M_max = boreRadius muY(Fz) Fz.

Loads on the rest of the model are the branch sums (SecondOrder/RingBody: the contact
mass feels sum_i w_i kT b_i); the outputs are those of SPEC 4 with the model's deflection
states replaced by U and, for DDT, the element forces by the (limited) branch forces F.
`Unlimited` is the linear model (one branch, no limit); it must agree with
reference.simulate, which this module's self-checks use.

Numerics: scipy solve_ivp, DOP853, rtol 1e-12, with terminal events at every stick/slide
switch (and at the kinks of the damped groups), so every piece is integrated on a smooth
right-hand side. A sliding spring group is put back exactly on its ellipse (radial scaling
of its deflections, a change of the order of the integration tolerance) at the end of every
piece. If Fz changes so that a spring group is outside its new limit, it is put on the limit
by the same radial scaling (the SPEC's "its force is put on the limit"; the tests here hold
Fz constant, so this choice is not exercised by them).

Not supported (not needed by the tests): lift-off (Fz <= 0), ramped vx or Fz, a DDT with
zero damping under friction.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

import reference as ref

# --------------------------------------------------------------------------- names

FRICTION_LAWS = {"Unlimited": 1, "Coulomb": 2, "Brush": 3}
FRICTION_NAMES = list(FRICTION_LAWS)
FRICTION_VR = 121
FRICTION_PARAMETER_VR = {"muX": 122, "muY": 123, "muLoadSensitivity": 124, "boreRadius": 125}
FRICTION_DEFAULTS = {"muX": 0.8, "muY": 0.8, "muLoadSensitivity": -0.1, "boreRadius": 0.1}
FRICTION_DEFAULT_LAW = "Brush"   # the FMU's start value (SPEC 3)

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
    """SPEC 4c: mu(Fz) = mu max(0, 1 + muLoadSensitivity (Fz/Fz0 - 1))."""
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

def ellipse_value(Fx, Fy, Lx, Ly):
    """f = (Fx/Lx)^2 + (Fy/Ly)^2 (1 on the ellipse)."""
    return (Fx / Lx) ** 2 + (Fy / Ly) ** 2


def spring_slide_multiplier(F, L, wC, g):
    """lambda of the associated flow of a sliding spring group (one entry per direction):
    n = F/L^2, lambda = sum n wC g / sum n wC n (lambda > 0: the motion pushes the force
    outward, the group slides; <= 0: it sticks again)."""
    n = [Fk / Lk ** 2 for Fk, Lk in zip(F, L)]
    num = sum(nk * ck * gk for nk, ck, gk in zip(n, wC, g))
    den = sum(nk * ck * nk for nk, ck in zip(n, wC))
    return num / den, n


def spring_slide_rate(F, L, wC, g):
    """db/dt of a sliding spring group: g - lambda n (force kept on the ellipse)."""
    lam, n = spring_slide_multiplier(F, L, wC, g)
    return [gk - lam * nk for gk, nk in zip(g, n)]


def damped_group_force(T, L, wD):
    """Force of a damped planar group from its trial force T (one entry per direction):
    T if inside the ellipse, else F_k = T_k / (1 + lam wD_k / L_k^2) with lam >= 0 such that
    sum (F_k/L_k)^2 = 1. The equation for lam is convex decreasing; Newton from the lower
    bound (sqrt(f) - 1)/max(a) converges monotonically."""
    q = [(Tk / Lk) ** 2 for Tk, Lk in zip(T, L)]
    f = sum(q)
    if not f > 1.0:
        return list(T)
    a = [wDk / Lk ** 2 for wDk, Lk in zip(wD, L)]
    lam = (math.sqrt(f) - 1.0) / max(a)
    for _ in range(100):
        h = sum(qk / (1.0 + lam * ak) ** 2 for qk, ak in zip(q, a)) - 1.0
        dh = -2.0 * sum(qk * ak / (1.0 + lam * ak) ** 3 for qk, ak in zip(q, a))
        step = -h / dh
        lam += step
        if abs(step) <= 1e-16 * lam:
            break
    return [Tk / (1.0 + lam * ak) for Tk, ak in zip(T, a)]


def clamp_moment(T, L):
    """Scalar damped group (DDT yaw): F = clamp(T, -L, L)."""
    return min(max(T, -L), L)


def damped_rate(F, w, C, D, b):
    """db/dt of a damped branch that carries the force F: (F/w - C b)/D."""
    return (F / w - C * b) / D


# --------------------------------------------------------------------------- the tire

class _Element:
    """One contact element: its stiffness C and damping D (whole element; branch i takes
    the fractions w_i), its branch-state slice, and its direction ('y', 'x' or 'psi')."""

    def __init__(self, direction, C, D, start, n):
        self.direction = direction
        self.C = C
        self.D = D
        self.ix = list(range(start, start + n))


class FrictionReferenceTire:
    """The friction reference behind the conftest.Tire interface (set, set_rates, step,
    outputs, get, run), so harness.wheel_cosim can drive it.

    State z = [non-element states..., lateral branches, longitudinal branches, yaw branches]
    with non-element states: SecondOrder [eta, w], RingBody [eta, w, xr, wx], else none.
    Inputs are held over each step (vy, steerRate and vsx may be ramped with set_rates;
    vx and Fz are held).
    """

    def __init__(self, model="DDT", friction="Brush", params=None, vx=0.0, vy=0.0,
                 steerRate=0.0, vsx=0.0, Fz=None):
        if model not in ref.MODELS:
            raise ValueError(model)
        self.model = model
        self.friction = friction
        self.branches = BRANCHES[friction]
        self.p = parameters(**(params or {}))
        self.q = ref.derived(self.p)
        self.inputs = {"vx": float(vx), "vy": float(vy), "steerRate": float(steerRate),
                       "vsx": float(vsx), "Fz": float(self.p["Fz0"] if Fz is None else Fz)}
        self.rates = {k: 0.0 for k in ref.DRIVING}
        self.t = 0.0
        self.n_events = 0        # stick/slide switches (and damped kinks) met so far
        nb = len(self.branches)
        self.others = {"RLT": [], "DDT": [], "SecondOrder": ["eta", "w"],
                       "RingBody": ["eta", "w", "xr", "wx"]}[model]
        self.io = {name: i for i, name in enumerate(self.others)}
        start = len(self.others)
        p, q = self.p, self.q
        if model == "RLT":
            spec = [("y", q["C_y"], 0.0), ("x", q["C_x"], 0.0)]
        elif model == "DDT":
            spec = [("y", q["C_y"], p["dampingY"]), ("x", q["C_x"], p["dampingX"]),
                    ("psi", p["stiffnessPsi"], p["dampingPsi"])]
        elif model == "SecondOrder":
            spec = [("y", q["kT_y"], 0.0), ("x", q["C_x"], 0.0)]
        else:
            spec = [("y", q["kT_y"], 0.0), ("x", q["kT_x"], 0.0)]
        self.el = {}
        for direction, C, D in spec:
            self.el[direction] = _Element(direction, C, D, start, nb)
            start += nb
        self.damped = model == "DDT"
        if self.damped and friction != "Unlimited" and min(e.D for e in self.el.values()) <= 0.0:
            raise NotImplementedError("DDT with zero damping under friction")
        self.z = np.zeros(start)
        self.slide = [False] * nb    # modes of the spring planar groups
        self.outside = {}            # sides of the damped groups' kinks (see _events)
        self._setup()

    # ---------------------------------------------------------------- per-step constants
    def _setup(self):
        p = self.p
        Fz = self.inputs["Fz"]
        if not Fz > 0.0:
            raise NotImplementedError("lift-off is not modelled by the friction reference")
        rho = abs(self.inputs["vx"])
        f_lat, f_long = ref.length_factors(p, Fz)
        lengths = {"RLT": {"y": p["sigmaY"] * f_lat, "x": p["sigmaX"] * f_long},
                   "DDT": {"y": p["sigmaY"] * f_lat, "x": p["sigmaX"] * f_long,
                           "psi": p["sigmaPsi"] * f_lat},
                   "SecondOrder": {"y": p["sigmaTread"] * f_lat, "x": p["sigmaX"] * f_long},
                   "RingBody": {"y": p["sigmaTread"] * f_lat, "x": p["sigmaTread"] * f_long}}
        self.relax = {d: rho / s for d, s in lengths[self.model].items()}
        self.sigma_y = p["sigmaY"] * f_lat      # for alphaT, kappaT
        self.sigma_x = p["sigmaX"] * f_long
        lim = limits(p, Fz)
        self.L = [{d: phi * lim[d] for d in ("x", "y", "psi")} for _, phi in self.branches]
        self.limited = self.friction != "Unlimited"
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
        """Driving inputs at time tau into the current step."""
        i, r = self.inputs, self.rates
        return (i["vy"] + r["vy"] * tau, i["steerRate"] + r["steerRate"] * tau,
                i["vsx"] + r["vsx"] * tau)

    # ---------------------------------------------------------------- element kinematics
    def _U(self, z, direction):
        e = self.el[direction]
        return sum(w * z[j] for (w, _), j in zip(self.branches, e.ix))

    def _drives(self, z, u):
        vy, r, vsx = u
        m = self.model
        if m == "RLT":
            return {"y": vy, "x": vsx}
        if m == "DDT":
            return {"y": vy + self.inputs["vx"] * self._U(z, "psi"), "x": vsx, "psi": r}
        if m == "SecondOrder":
            return {"y": z[self.io["w"]], "x": vsx}
        return {"y": z[self.io["w"]], "x": z[self.io["wx"]]}

    def _stick_rates(self, z, u):
        """g[d][i] = drive_d - (rho/sigma_d) b_i for every element d and branch i."""
        drive = self._drives(z, u)
        return {d: [drive[d] - self.relax[d] * z[j] for j in e.ix] for d, e in self.el.items()}

    def _forces(self, z, u, g=None):
        """Branch forces F[d][i] (springs: w C b; damped: the limited trial force)."""
        F = {d: [w * e.C * z[j] for (w, _), j in zip(self.branches, e.ix)]
             for d, e in self.el.items()}
        if not self.damped:
            return F
        g = self._stick_rates(z, u) if g is None else g
        for d, e in self.el.items():
            for i, (w, _) in enumerate(self.branches):
                F[d][i] += w * e.D * g[d][i]
        if self.limited:
            ex, ey, ep = self.el["x"], self.el["y"], self.el["psi"]
            for i, (w, _) in enumerate(self.branches):
                L = self.L[i]
                Fy, Fx = damped_group_force((F["y"][i], F["x"][i]), (L["y"], L["x"]),
                                            (w * ey.D, w * ex.D))
                F["y"][i], F["x"][i] = Fy, Fx
                F["psi"][i] = clamp_moment(F["psi"][i], L["psi"])
        return F

    # ---------------------------------------------------------------- right-hand side
    def _rhs(self, tau, z):
        u = self._u(tau)
        g = self._stick_rates(z, u)
        dz = np.empty_like(z)
        if self.damped:
            F = self._forces(z, u, g)
            for d, e in self.el.items():
                for i, ((w, _), j) in enumerate(zip(self.branches, e.ix)):
                    dz[j] = damped_rate(F[d][i], w, e.C, e.D, z[j])
            return dz
        F = self._forces(z, u)
        ey, ex = self.el["y"], self.el["x"]
        for i, (w, _) in enumerate(self.branches):
            gy, gx = g["y"][i], g["x"][i]
            if self.slide[i]:
                L = self.L[i]
                gy, gx = spring_slide_rate((F["y"][i], F["x"][i]), (L["y"], L["x"]),
                                           (w * ey.C, w * ex.C), (gy, gx))
            dz[ey.ix[i]] = gy
            dz[ex.ix[i]] = gx
        if self.model in ("SecondOrder", "RingBody"):
            self._contact_mass_rates(z, u, F, dz)
        return dz

    def _contact_mass_rates(self, z, u, F, dz):
        """SPEC 4 contact-mass equations with the tread force sum_i F_i."""
        p, q, io = self.p, self.q, self.io
        vy, _, vsx = u
        mass, damping = ((p["contactMass"], p["carcassDampingY"]) if self.model == "SecondOrder"
                         else (p["ringMass"], p["ringDampingY"]))
        eta, w = z[io["eta"]], z[io["w"]]
        dz[io["eta"]] = w - vy
        dz[io["w"]] = (-sum(F["y"]) - q["k_y"] * eta - damping * (w - vy)) / mass
        if self.model == "RingBody":
            mx = p["ringInertia"] / p["Re"] ** 2
            xr, wx = z[io["xr"]], z[io["wx"]]
            dz[io["xr"]] = wx - vsx
            dz[io["wx"]] = (-sum(F["x"]) - q["k_x"] * xr - p["ringDampingX"] * (wx - vsx)) / mx

    # ---------------------------------------------------------------- events
    def _group_f(self, z, u, i, F=None):
        """Ellipse value of planar group i (springs: of F; damped: of the trial force)."""
        if F is None:
            F = self._trial_forces(z, u)
        L = self.L[i]
        return ellipse_value(F["x"][i], F["y"][i], L["x"], L["y"])

    def _trial_forces(self, z, u):
        """Unlimited branch forces: w C b (+ w D g for damped elements)."""
        F = {d: [w * e.C * z[j] for (w, _), j in zip(self.branches, e.ix)]
             for d, e in self.el.items()}
        if self.damped:
            g = self._stick_rates(z, u)
            for d, e in self.el.items():
                for i, (w, _) in enumerate(self.branches):
                    F[d][i] += w * e.D * g[d][i]
        return F

    def _lambda(self, z, u, i):
        F = self._trial_forces(z, u)
        g = self._stick_rates(z, u)
        w = self.branches[i][0]
        L = self.L[i]
        lam, _ = spring_slide_multiplier((F["y"][i], F["x"][i]), (L["y"], L["x"]),
                                         (w * self.el["y"].C, w * self.el["x"].C),
                                         (g["y"][i], g["x"][i]))
        return lam

    def _events(self):
        """Terminal event functions for the current modes, with their meaning.

        Spring groups: sticking -> f(F) rising through 1 (starts sliding); sliding ->
        lambda falling through 0 (sticks again). Damped groups (DDT) have no modes, but
        the integration stops where the trial force crosses the limit (a kink of the
        right-hand side); `self.outside` records on which side each kink currently is so
        every event function only looks for the crossing away from that side."""
        evs, info = [], []

        def add(fun, direction, what):
            fun.terminal = True
            fun.direction = direction
            evs.append(fun)
            info.append(what)

        for i in range(len(self.branches)):
            if self.damped:
                side = self.outside[("xy", i)]
                add(lambda t, z, i=i: self._group_f(z, self._u(t), i) - 1.0,
                    -1.0 if side else 1.0, ("xy", i))
                L = self.L[i]["psi"]
                side = self.outside[("psi", i)]
                if side >= 0:
                    add(lambda t, z, i=i, L=L: self._trial_forces(z, self._u(t))["psi"][i] - L,
                        -1.0 if side else 1.0, ("psi+", i))
                if side <= 0:
                    add(lambda t, z, i=i, L=L: self._trial_forces(z, self._u(t))["psi"][i] + L,
                        1.0 if side else -1.0, ("psi-", i))
            elif self.slide[i]:
                add(lambda t, z, i=i: self._lambda(z, self._u(t), i), -1.0, ("stick", i))
            else:
                add(lambda t, z, i=i: self._group_f(z, self._u(t), i) - 1.0, 1.0, ("slide", i))
        return evs, info

    def _event_happened(self, kind, i):
        """Switch the mode (spring groups) or the recorded side (damped kinks)."""
        if kind == "slide":
            self.slide[i] = True
            self._put_on_ellipse(i)
        elif kind == "stick":
            self.slide[i] = False
        elif kind == "xy":
            self.outside[("xy", i)] = not self.outside[("xy", i)]
        elif kind == "psi+":
            self.outside[("psi", i)] = 0 if self.outside[("psi", i)] else 1
        elif kind == "psi-":
            self.outside[("psi", i)] = 0 if self.outside[("psi", i)] else -1

    # ---------------------------------------------------------------- modes
    def _put_on_ellipse(self, i):
        """Radially scale spring group i onto its ellipse if it is outside (or, when
        sliding, anywhere off it)."""
        z = self.z
        f = self._group_f(z, self._u(0.0), i)
        s = 1.0 / math.sqrt(f)
        for d in ("y", "x"):
            j = self.el[d].ix[i]
            z[j] *= s

    def _decide_modes(self, tau):
        """At the start of a step (new inputs). Spring groups: outside -> put on the limit;
        on the ellipse -> slide iff the motion pushes outward (lambda > 0); inside -> stick.
        Damped groups: record on which side of each kink the trial force is."""
        if not self.limited:
            return
        u = self._u(tau)
        if self.damped:
            T = self._trial_forces(self.z, u)
            for i in range(len(self.branches)):
                self.outside[("xy", i)] = self._group_f(self.z, u, i, T) > 1.0
                L = self.L[i]["psi"]
                self.outside[("psi", i)] = 1 if T["psi"][i] > L else (-1 if T["psi"][i] < -L else 0)
            return
        for i in range(len(self.branches)):
            f = self._group_f(self.z, u, i)
            if f > 1.0 + ON_LIMIT:
                self._put_on_ellipse(i)
                f = 1.0
            self.slide[i] = f >= 1.0 - ON_LIMIT and self._lambda(self.z, u, i) > 0.0

    # ---------------------------------------------------------------- stepping
    def step(self, h):
        """Advance by h with the inputs held (vy, steerRate, vsx ramped by their rates)."""
        if (self.inputs["vx"], self.inputs["Fz"]) != self._key:
            self._setup()
        tau = 0.0
        self._decide_modes(tau)
        pieces = 0
        while tau < h:
            pieces += 1
            if pieces > 10000:
                raise RuntimeError("too many stick/slide switches in one step")
            if self.limited:
                evs, info = self._events()
            else:
                evs, info = [], []
            sol = solve_ivp(self._rhs, (tau, h), self.z, method="DOP853", rtol=RTOL, atol=ATOL,
                            events=evs or None)
            if sol.status < 0:
                raise RuntimeError(sol.message)
            self.z = sol.y[:, -1].copy()
            tau = sol.t[-1] if sol.status == 1 else h
            if sol.status == 1:
                self.n_events += 1
                k = next(k for k, te in enumerate(sol.t_events) if len(te))
                self._event_happened(*info[k])
            # sliding spring groups: remove the integration drift off the ellipse
            for i, sliding in enumerate(self.slide):
                if sliding and not self.damped:
                    self._put_on_ellipse(i)
        for k in ref.DRIVING:
            self.inputs[k] += h * self.rates[k]
        self.t += h

    # ---------------------------------------------------------------- outputs
    def branch_forces(self):
        """Branch forces {direction: [F_i]} at the current state and inputs."""
        return self._forces(self.z, self._u(0.0))

    def ellipse_values(self):
        """(F_x,i / L_x,i)^2 + (F_y,i / L_y,i)^2 of every planar group (<= 1)."""
        F = self.branch_forces()
        return [ellipse_value(F["x"][i], F["y"][i], L["x"], L["y"]) for i, L in enumerate(self.L)]

    def outputs(self):
        """All nine outputs (reference.OUTPUTS order) at the current state and inputs."""
        if (self.inputs["vx"], self.inputs["Fz"]) != self._key:
            self._setup()
        z, u = self.z, self._u(0.0)
        p, q, io = self.p, self.q, self.io
        vy, _, vsx = u
        F = self._forces(z, u)
        fy_el, fx_el = sum(F["y"]), sum(F["x"])
        defl_y, defl_x = self._U(z, "y"), self._U(z, "x")
        defl_psi = 0.0
        yaw = 0.0
        my = None
        if self.model in ("RLT", "DDT"):
            fy, fx = -fy_el, -fx_el
            if self.model == "DDT":
                yaw = -sum(F["psi"])
                defl_psi = self._U(z, "psi")
        else:
            damping = p["carcassDampingY"] if self.model == "SecondOrder" else p["ringDampingY"]
            eta, w = z[io["eta"]], z[io["w"]]
            fy = q["k_y"] * eta + damping * (w - vy)
            defl_y = defl_y - eta
            fx = -fx_el
            if self.model == "RingBody":
                xr, wx = z[io["xr"]], z[io["wx"]]
                my = -p["Re"] * (q["k_x"] * xr + p["ringDampingX"] * (wx - vsx))
                defl_x = defl_x - xr
        if my is None:
            my = -p["Re"] * fx
        y = {"Fx": fx, "Fy": fy, "Mz": yaw - p["trail"] * fy, "My": my,
             "alphaT": -defl_y / self.sigma_y, "kappaT": -defl_x / self.sigma_x,
             "deflX": defl_x, "deflY": defl_y, "deflPsi": defl_psi}
        return np.array([y[o] for o in ref.OUTPUTS])

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
    tire = FrictionReferenceTire(model, friction, params=p, vx=vxs[0],
                                 Fz=None if Fz is None else np.broadcast_to(Fz, (N,))[0])
    return tire.run(U, h, dU=dU, vx=vxs, Fz=Fz)
