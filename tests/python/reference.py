"""Independent reference implementation of the TireLag models (docs/specification.md 3-5).

Everything here is written from the project specification only:

* ``parameters()``    -- the default parameter set (the modelDescription start values),
* ``derived()``       -- the derived stiffnesses of docs/specification.md 3,
* ``system()``        -- A, B, C, D of docs/specification.md 4 for one model at one speed,
* ``zoh()/foh()``     -- exact discretisation by the matrix exponential of an augmented matrix,
* ``simulate()``      -- exact stepping of piecewise-constant or piecewise-linear inputs,
* ``transfer()``      -- the transfer functions of docs/specification.md 5, evaluated at complex s
                         (written from the section 5 formulas, *not* from A, B, C, D).

State vectors (all start at 0):
  RLT         [uY, uX]
  DDT         [uPsi, uY, uX]
  SecondOrder [eta, uT, w, uX]
  RingBody    [eta, uT, w, xr, uTx, wx]
Driving inputs u = [vy, steerRate, vsx]; vx (and Fz) select the system.
Outputs y = C x + D u, in the order of OUTPUTS.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm

# --------------------------------------------------------------------------- names

MODELS = {"RLT": 1, "DDT": 2, "SecondOrder": 3, "RingBody": 4}
MODEL_NAMES = list(MODELS)

INPUTS = ["vx", "vy", "steerRate", "vsx", "Fz"]
INPUT_VR = {"vx": 1, "vy": 2, "steerRate": 3, "vsx": 4, "Fz": 5}
DRIVING = ["vy", "steerRate", "vsx"]  # u, in this order

OUTPUTS = ["Fx", "Fy", "Mz", "My", "alphaT", "kappaT", "deflX", "deflY", "deflPsi"]
OUTPUT_VR = {name: vr for name, vr in zip(OUTPUTS, range(11, 20))}
OUT = {name: i for i, name in enumerate(OUTPUTS)}
LOADS = ["Fx", "Fy", "Mz", "My"]

MODEL_VR = 100
PARAMETER_VR = {
    "Calpha": 101, "Ckappa": 102, "sigmaY": 103, "sigmaX": 104, "Re": 105, "trail": 106,
    "Fz0": 107, "dampingY": 108, "dampingX": 109, "sigmaPsi": 110, "stiffnessPsi": 111,
    "dampingPsi": 112, "contactMass": 113, "carcassDampingY": 114, "ringMass": 115,
    "ringInertia": 116, "ringDampingY": 117, "ringDampingX": 118, "sigmaTread": 119,
    "calphaLoadPeak": 120,
}
DEFAULTS = {
    "Calpha": 350000.0, "Ckappa": 500000.0, "sigmaY": 1.0, "sigmaX": 0.5, "Re": 0.6,
    "trail": 0.05, "Fz0": 50000.0, "dampingY": 9000.0, "dampingX": 9000.0,
    "sigmaPsi": 0.45, "stiffnessPsi": 40000.0, "dampingPsi": 400.0, "contactMass": 20.0,
    "carcassDampingY": 9000.0, "ringMass": 30.0, "ringInertia": 8.0,
    "ringDampingY": 9000.0, "ringDampingX": 9000.0, "sigmaTread": 0.1,
    "calphaLoadPeak": 2.0,
}
STATES = {
    "RLT": ["uY", "uX"],
    "DDT": ["uPsi", "uY", "uX"],
    "SecondOrder": ["eta", "uT", "w", "uX"],
    "RingBody": ["eta", "uT", "w", "xr", "uTx", "wx"],
}

# docs/specification.md 9: snowblower tire (Koo & Tan Table 1, per tire)
SNOWBLOWER = {"Calpha": 350000.0, "sigmaY": 1.0, "sigmaPsi": 0.45, "dampingY": 9000.0,
              "stiffnessPsi": 40000.0}

LIFT_OFF_TIME_CONSTANT = 0.01  # s (FMU documentation: states decay with 0.01 s when Fz <= 0)


def parameters(**overrides) -> dict:
    p = dict(DEFAULTS)
    for k, v in overrides.items():
        if k not in p:
            raise KeyError(k)
        p[k] = float(v)
    return p


def derived(p: dict) -> dict:
    """Derived stiffnesses of docs/specification.md 3 (never separate parameters)."""
    return {
        "C_y": p["Calpha"] / p["sigmaY"],          # Koo & Tan eq 16
        "C_x": p["Ckappa"] / p["sigmaX"],
        "k_y": p["Calpha"] / (p["sigmaY"] - p["sigmaTread"]),
        "k_x": p["Ckappa"] / (p["sigmaX"] - p["sigmaTread"]),
        "kT_y": p["Calpha"] / p["sigmaTread"],
        "kT_x": p["Ckappa"] / p["sigmaTread"],
    }


def cornering_stiffness_at(p: dict, Fz: float) -> float:
    """docs/specification.md 4b: Calpha(Fz) = Calpha x (1 + 1/c2^2)/(1 + x^2/c2^2), x = Fz/Fz0."""
    x, c2 = Fz / p["Fz0"], p["calphaLoadPeak"]
    return p["Calpha"] * x * (1.0 + 1.0 / c2**2) / (1.0 + x**2 / c2**2)


def length_factors(p: dict, Fz) -> tuple:
    """How the load stretches the relaxation lengths (docs/specification.md 4b): lateral lengths by
    Calpha(Fz)/Calpha, longitudinal ones by Ckappa(Fz)/Ckappa = Fz/Fz0; nominal (1, 1)
    when Fz is None or the wheel is off the ground."""
    if Fz is None or Fz <= 0.0:
        return 1.0, 1.0
    return cornering_stiffness_at(p, Fz) / p["Calpha"], Fz / p["Fz0"]


# --------------------------------------------------------------------------- state space

class _Builder:
    """Fills A, B and output rows by state *name*, so the equations read like docs/specification.md 4."""

    def __init__(self, states):
        self.states = list(states)
        self.ix = {s: i for i, s in enumerate(states)}
        n = len(states)
        self.A = np.zeros((n, n))
        self.B = np.zeros((n, 3))
        self.rows = {}

    def ddt(self, state, x=None, u=None):
        """d state/dt = sum x[k]*state_k + sum u[k]*input_k"""
        i = self.ix[state]
        for k, v in (x or {}).items():
            self.A[i, self.ix[k]] += v
        for k, v in (u or {}).items():
            self.B[i, DRIVING.index(k)] += v

    def combo(self, x=None, u=None):
        c = np.zeros(len(self.states))
        d = np.zeros(3)
        for k, v in (x or {}).items():
            c[self.ix[k]] += v
        for k, v in (u or {}).items():
            d[DRIVING.index(k)] += v
        return c, d

    def derivative(self, state):
        """The row (c, d) with c x + d u = d state/dt."""
        i = self.ix[state]
        return self.A[i].copy(), self.B[i].copy()


def _scale(row, k):
    return row[0] * k, row[1] * k


def _add(*rows):
    c = sum(r[0] for r in rows)
    d = sum(r[1] for r in rows)
    return c, d


def system(model: str, p: dict, vx: float, lifted_off: bool = False, Fz=None):
    """A, B, C, D of docs/specification.md 4 (u = [vy, steerRate, vsx], y in OUTPUTS order) at the
    normal load Fz (None: nominal). The stiffnesses stay at their Fz0 values; the
    relaxation lengths stretch with the load (docs/specification.md 4b)."""
    q = derived(p)
    rho = abs(vx)
    f_lat, f_long = length_factors(p, None if lifted_off else Fz)
    sigma_y, sigma_x, sigma_psi = p["sigmaY"] * f_lat, p["sigmaX"] * f_long, p["sigmaPsi"] * f_lat
    tread_y, tread_x = p["sigmaTread"] * f_lat, p["sigmaTread"] * f_long
    b = _Builder(STATES[model])
    zero = b.combo()

    def lateral_contact(mass, damping):
        # deta/dt = w - vy ; duT/dt = w - (rho/sigmaTread) uT
        # m dw/dt = -kT_y uT - k_y eta - d (w - vy)
        b.ddt("eta", {"w": 1.0}, {"vy": -1.0})
        b.ddt("uT", {"w": 1.0, "uT": -rho / tread_y})
        b.ddt("w", {"uT": -q["kT_y"] / mass, "eta": -q["k_y"] / mass, "w": -damping / mass},
              {"vy": damping / mass})
        fy = b.combo({"eta": q["k_y"], "w": damping}, {"vy": -damping})
        defl_y = b.combo({"uT": 1.0, "eta": -1.0})
        return fy, defl_y

    def longitudinal_rlt():
        b.ddt("uX", {"uX": -rho / sigma_x}, {"vsx": 1.0})
        return b.combo({"uX": -q["C_x"]}), b.combo({"uX": 1.0})

    yaw = zero   # DDT's yaw moment, without the trail term
    my = None    # None: My = -Re Fx
    defl_psi = zero
    if model == "RLT":
        b.ddt("uY", {"uY": -rho / sigma_y}, {"vy": 1.0})
        fy = b.combo({"uY": -q["C_y"]})
        defl_y = b.combo({"uY": 1.0})
        fx, defl_x = longitudinal_rlt()
    elif model == "DDT":
        b.ddt("uPsi", {"uPsi": -rho / sigma_psi}, {"steerRate": 1.0})
        b.ddt("uY", {"uY": -rho / sigma_y, "uPsi": vx}, {"vy": 1.0})
        b.ddt("uX", {"uX": -rho / sigma_x}, {"vsx": 1.0})
        fy = _scale(_add(b.combo({"uY": q["C_y"]}), _scale(b.derivative("uY"), p["dampingY"])), -1.0)
        fx = _scale(_add(b.combo({"uX": q["C_x"]}), _scale(b.derivative("uX"), p["dampingX"])), -1.0)
        yaw = _scale(_add(b.combo({"uPsi": p["stiffnessPsi"]}),
                          _scale(b.derivative("uPsi"), p["dampingPsi"])), -1.0)
        defl_y = b.combo({"uY": 1.0})
        defl_x = b.combo({"uX": 1.0})
        defl_psi = b.combo({"uPsi": 1.0})
    elif model == "SecondOrder":
        fy, defl_y = lateral_contact(p["contactMass"], p["carcassDampingY"])
        fx, defl_x = longitudinal_rlt()
    elif model == "RingBody":
        fy, defl_y = lateral_contact(p["ringMass"], p["ringDampingY"])
        mx = p["ringInertia"] / p["Re"] ** 2
        dx = p["ringDampingX"]
        # dxr/dt = wx - vsx ; duTx/dt = wx - (rho/sigmaTread) uTx
        # m_x dwx/dt = -kT_x uTx - k_x xr - ringDampingX (wx - vsx)
        b.ddt("xr", {"wx": 1.0}, {"vsx": -1.0})
        b.ddt("uTx", {"wx": 1.0, "uTx": -rho / tread_x})
        b.ddt("wx", {"uTx": -q["kT_x"] / mx, "xr": -q["k_x"] / mx, "wx": -dx / mx},
              {"vsx": dx / mx})
        fx = b.combo({"uTx": -q["kT_x"]})
        my = _scale(b.combo({"xr": q["k_x"], "wx": dx}, {"vsx": -dx}), -p["Re"])
        defl_x = b.combo({"uTx": 1.0, "xr": -1.0})
    else:
        raise ValueError(model)

    if my is None:
        my = _scale(fx, -p["Re"])
    mz = _add(yaw, _scale(fy, -p["trail"]))
    rows = {
        "Fx": fx, "Fy": fy, "Mz": mz, "My": my,
        "alphaT": _scale(defl_y, -1.0 / sigma_y),
        "kappaT": _scale(defl_x, -1.0 / sigma_x),
        "deflX": defl_x, "deflY": defl_y, "deflPsi": defl_psi,
    }
    C = np.array([rows[o][0] for o in OUTPUTS])
    D = np.array([rows[o][1] for o in OUTPUTS])
    A, B = b.A, b.B
    if lifted_off:
        n = A.shape[0]
        A = -np.eye(n) / LIFT_OFF_TIME_CONSTANT
        B = np.zeros_like(B)
        D = np.zeros_like(D)
        for o in LOADS:
            C[OUT[o]] = 0.0
    return A, B, C, D


# --------------------------------------------------------------------------- exact stepping

def zoh(A, B, h):
    """x(t+h) = Phi x + Gamma u for u held constant (expm of [[A, B], [0, 0]] h)."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n] = A
    M[:n, n:] = B
    E = expm(M * h)
    return E[:n, :n], E[:n, n:]


def foh(A, B, h):
    """x(t+h) = Phi x + G0 u0 + G1 du for u(t + tau) = u0 + du tau (ramp).

    expm of [[A, B, 0], [0, 0, I], [0, 0, 0]] h: the augmented state is [x, u, du].
    """
    n, m = B.shape
    M = np.zeros((n + 2 * m, n + 2 * m))
    M[:n, :n] = A
    M[:n, n:n + m] = B
    M[n:n + m, n + m:] = np.eye(m)
    E = expm(M * h)
    return E[:n, :n], E[:n, n:n + m], E[:n, n + m:]


def simulate(model, p, vx, U, h, dU=None, Fz=None, x0=None, return_states=False):
    """Exact response to inputs held (or ramped) over steps of size h.

    vx: scalar or array (one value per step, held over the step).
    U:  (N, 3) driving inputs [vy, steerRate, vsx] at the start of each step.
    dU: (N, 3) input rates over each step (ramps), or None for piecewise constant.
    Fz: None (always loaded) or array of normal loads, one per step.
    Returns Y (N, 9): outputs at the end of each step, y = C x(t_k + h) + D u(t_k + h),
    where u(t_k + h) = U[k] + h dU[k] (the inputs the FMU holds after the step).
    """
    U = np.atleast_2d(np.asarray(U, dtype=float))
    N = U.shape[0]
    vxs = np.broadcast_to(np.asarray(vx, dtype=float), (N,))
    hs = np.broadcast_to(np.asarray(h, dtype=float), (N,))
    loads = None if Fz is None else np.broadcast_to(np.asarray(Fz, float), (N,))
    lifted = np.zeros(N, bool) if loads is None else loads <= 0.0
    n = len(STATES[model])
    x = np.zeros(n) if x0 is None else np.array(x0, dtype=float)
    Y = np.empty((N, len(OUTPUTS)))
    X = np.empty((N, n))
    cache = {}
    for k in range(N):
        load = None if loads is None else float(loads[k])
        key = (vxs[k], hs[k], load, dU is not None)
        if key not in cache:
            A, B, C, D = system(model, p, vxs[k], lifted_off=bool(lifted[k]), Fz=load)
            if dU is None:
                Phi, G0 = zoh(A, B, hs[k])
                G1 = None
            else:
                Phi, G0, G1 = foh(A, B, hs[k])
            cache[key] = (Phi, G0, G1, C, D)
        Phi, G0, G1, C, D = cache[key]
        u = U[k]
        if dU is None:
            x = Phi @ x + G0 @ u
            u_end = u
        else:
            x = Phi @ x + G0 @ u + G1 @ dU[k]
            u_end = u + hs[k] * dU[k]
        X[k] = x
        Y[k] = C @ x + D @ u_end
    if return_states:
        return Y, X
    return Y


def state_space_response(model, p, vx, s):
    """G(s) = C (sI - A)^-1 B + D, shape (len(s), 9, 3): a cross-check of system()."""
    A, B, C, D = system(model, p, vx)
    s = np.atleast_1d(np.asarray(s, dtype=complex))
    n = A.shape[0]
    out = np.empty((len(s), C.shape[0], B.shape[1]), dtype=complex)
    for i, si in enumerate(s):
        out[i] = C @ np.linalg.solve(si * np.eye(n) - A, B) + D
    return out


# --------------------------------------------------------------------------- docs/specification.md 5

def transfer(model: str, p: dict, vx: float, s):
    """Transfer functions of docs/specification.md 5 at Laplace variable(s) s.

    Returns a dict with complex arrays for
      'Fy/vy', 'Fy/steerRate', 'Mz/vy', 'Mz/steerRate', 'Fx/vsx', 'My/vsx'.
    Fy = -Z vy (lateral impedance Z), Fx = -Zx vsx, Mz = yaw - trail Fy, My = -Re Fx
    (RingBody: Fx and My from the circumferential formulas).
    """
    s = np.asarray(s, dtype=complex)
    q = derived(p)
    rho = abs(vx)
    zero = np.zeros_like(s)

    def contact_impedance(k, kT, mass, damping):
        Zc = k / s + damping
        Zm = mass * s + kT / (s + rho / p["sigmaTread"])
        return Zc, Zm

    fy_r = zero
    mz_yaw_r = zero
    if model == "RLT":
        Z = q["C_y"] / (s + rho / p["sigmaY"])
        Zx = q["C_x"] / (s + rho / p["sigmaX"])
    elif model == "DDT":
        Z = (p["dampingY"] * s + q["C_y"]) / (s + rho / p["sigmaY"])
        Zx = (p["dampingX"] * s + q["C_x"]) / (s + rho / p["sigmaX"])
        psi_r = 1.0 / (s + rho / p["sigmaPsi"])          # uPsi / r
        fy_r = -Z * vx * psi_r
        mz_yaw_r = -(p["stiffnessPsi"] + p["dampingPsi"] * s) * psi_r
    elif model in ("SecondOrder", "RingBody"):
        if model == "SecondOrder":
            Zc, Zm = contact_impedance(q["k_y"], q["kT_y"], p["contactMass"], p["carcassDampingY"])
        else:
            Zc, Zm = contact_impedance(q["k_y"], q["kT_y"], p["ringMass"], p["ringDampingY"])
        Z = Zc * Zm / (Zc + Zm)
        Zx = q["C_x"] / (s + rho / p["sigmaX"])
    else:
        raise ValueError(model)

    fy_vy = -Z
    if model == "RingBody":
        mx = p["ringInertia"] / p["Re"] ** 2
        Zc = q["k_x"] / s + p["ringDampingX"]
        Zm = mx * s + q["kT_x"] / (s + rho / p["sigmaTread"])
        fx_vsx = -(q["kT_x"] / (s + rho / p["sigmaTread"])) * Zc / (Zc + Zm)
        my_vsx = p["Re"] * Zc * Zm / (Zc + Zm)
    else:
        fx_vsx = -Zx
        my_vsx = -p["Re"] * fx_vsx
    return {
        "Fy/vy": fy_vy,
        "Fy/steerRate": fy_r,
        "Mz/vy": -p["trail"] * fy_vy,
        "Mz/steerRate": mz_yaw_r - p["trail"] * fy_r,
        "Fx/vsx": fx_vsx,
        "My/vsx": my_vsx,
    }


def wheel_mass_polynomial(p, vx, m_w, model):
    """Koo & Tan eqs 41 (RLT) and 44 (DDT): denominator m_w s^2 + (m_w a + D) s + C_y."""
    a = abs(vx) / p["sigmaY"]
    D = p["dampingY"] if model == "DDT" else 0.0
    return np.array([m_w, m_w * a + D, p["Calpha"] / p["sigmaY"]])


class ReferenceTire:
    """The reference model behind the same small interface as conftest.Tire
    (set, set_rates, step, outputs, run), stepping exactly with zoh/foh.

    FMI semantics mirrored: inputs are held over a step, or ramped with the rates set by
    set_rates; after a step the inputs are advanced to the ramp's end value and the rates
    are kept. Fz <= 0 switches to the lifted-off system.
    """

    def __init__(self, model="DDT", params=None, vx=0.0, vy=0.0, steerRate=0.0, vsx=0.0, Fz=None):
        self.model = model
        self.params = parameters(**(params or {}))
        self.inputs = {"vx": vx, "vy": vy, "steerRate": steerRate, "vsx": vsx,
                       "Fz": self.params["Fz0"] if Fz is None else Fz}
        self.rates = {k: 0.0 for k in self.inputs}
        self.x = np.zeros(len(STATES[model]))
        self.t = 0.0
        self._cache = {}

    def set(self, **inputs):
        for k, v in inputs.items():
            self.inputs[k] = float(v)

    def set_rates(self, **rates):
        for k, v in rates.items():
            self.rates[k] = float(v)

    def _u(self, values):
        return np.array([values[k] for k in DRIVING])

    def _system(self):
        key = ("sys", self.inputs["vx"], self.inputs["Fz"])
        if key not in self._cache:
            self._cache[key] = system(self.model, self.params, self.inputs["vx"],
                                      lifted_off=self.inputs["Fz"] <= 0.0, Fz=self.inputs["Fz"])
        return self._cache[key]

    def outputs(self):
        A, B, C, D = self._system()
        return C @ self.x + D @ self._u(self.inputs)

    def get(self, *names):
        y = self.outputs()
        return np.array([y[OUT[n]] for n in names])

    def step(self, h):
        if any(self.rates[k] != 0.0 for k in ("vx", "Fz")):
            raise NotImplementedError("ramped vx or Fz")
        key = ("step", self.inputs["vx"], self.inputs["Fz"], h)
        if key not in self._cache:
            A, B, C, D = self._system()
            self._cache[key] = foh(A, B, h)
        Phi, G0, G1 = self._cache[key]
        self.x = Phi @ self.x + G0 @ self._u(self.inputs) + G1 @ self._u(self.rates)
        for k in self.inputs:
            self.inputs[k] += h * self.rates[k]
        self.t += h

    def run(self, U, h, dU=None, vx=None, Fz=None):
        U = np.atleast_2d(np.asarray(U, dtype=float))
        N = U.shape[0]
        hs = np.broadcast_to(np.asarray(h, dtype=float), (N,))
        Y = np.empty((N, len(OUTPUTS)))
        for k in range(N):
            if vx is not None:
                self.set(vx=np.broadcast_to(vx, (N,))[k])
            if Fz is not None:
                self.set(Fz=np.broadcast_to(Fz, (N,))[k])
            self.set(**dict(zip(DRIVING, U[k])))
            if dU is not None:
                self.set_rates(**dict(zip(DRIVING, dU[k])))
            self.step(float(hs[k]))
            Y[k] = self.outputs()
        return Y

    def close(self):
        pass
