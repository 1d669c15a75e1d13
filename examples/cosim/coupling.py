"""The co-simulation master: a linear vehicle body coupled to tire blocks, implicitly.

A vehicle model (see ``vehicle.py``) describes, in plain equations,

* its body:        dx/dt = f(x, tire outputs, their rates, external inputs, their rates)
* the tire inputs: u     = g(x, tire outputs, external inputs, their rates)

with f and g linear (small-angle vehicle dynamics). The master turns them into matrices
by evaluating them on unit vectors, and steps the coupled system with communication
step h:

* External inputs (the steer angle, disturbance moments) are given at the communication
  points and are linear in between, so their rates are constant over a step.
* Each tire gets its coupled inputs as a ramp from the value at the start of the step to
  the value at its end (fmi2SetRealInputDerivatives); the FMU steps that ramp exactly.
  The FMI 3.0 FMU has no input derivatives: it gets the ramp's mean, held over the step
  (``tire.TireLag.advance``), which keeps the coupling implicit and second order.
* The body is stepped exactly (matrix exponential) with the tire outputs ramping linearly
  between their values at the two ends of the step.
* The ramp's end value depends on the body state at the end of the step, which depends on
  the tire outputs at the end of the step: the coupling is implicit. The master solves it
  by a Newton iteration on the tire inputs at the end of the step, with the tires'
  step sensitivity S = d(outputs at end)/d(inputs at end) measured once by probing
  (fmi2GetFMUstate/fmi2SetFMUstate). The tires are linear, so one Newton correction is
  exact: each step costs a trial step and the final step per tire. A nonlinear tire (a
  friction limit) needs more iterations; S is measured again at the current state when
  the iteration is slow.

The only approximation is that the coupling signals are taken as linear within a step
(first-order hold on both sides). It is second order in h: a frequency response at
angular frequency w is off by about (w h)^2/6, e.g. 7e-4 at 1 Hz with 10 ms steps and
3e-7 at 1 Hz with 0.2 ms steps. Constant and ramp-shaped signals are exact, so steady
states are exact at any h. (With the FMI 3.0 FMU ramps are not exact, the held means add
an error of the same order, and steady states stay exact.)

A rate term of a tire output in the body equations (a damper across a tire deflection,
such as Koo & Tan's c1) is handled exactly by a change of state, zeta = x - B_rate y;
such outputs must have no direct feedthrough from the inputs (deflections do not).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Protocol, Sequence

import numpy as np
from scipy.linalg import expm


class TireBlock(Protocol):
    """What the master needs from a tire (``tire.TireLag``, ``tire.SteadyStateTire``)."""

    name: str
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]

    def set_inputs(self, **values: float) -> None: ...
    def begin_step(self, u_start: np.ndarray) -> np.ndarray: ...
    def save(self) -> None: ...
    def restore(self) -> None: ...
    def advance(self, h: float, u_start: np.ndarray, u_end: np.ndarray) -> np.ndarray: ...
    def close(self) -> None: ...


class VehicleModel(Protocol):
    """A vehicle body for the master (see ``vehicle.Bicycle``).

    ``derivatives`` and ``tire_inputs`` must be linear in their arguments. They receive
    ``x``, ``ext`` and ``ext_rate`` as {name: value} and the tire outputs (and their
    rates) as {corner: {output: value}}.
    """

    state_names: tuple[str, ...]
    external_names: tuple[str, ...]
    tires: Mapping[str, TireBlock]            # corner name -> tire

    def fixed_tire_inputs(self) -> Mapping[str, Mapping[str, float]]: ...
    def derivatives(self, x, tire, tire_rate, ext, ext_rate) -> Sequence[float]: ...
    def tire_inputs(self, x, tire, ext, ext_rate) -> Mapping[str, Mapping[str, float]]: ...


class CouplingError(RuntimeError):
    """The implicit coupling did not converge within the allowed iterations."""


def first_order_hold(A: np.ndarray, B: np.ndarray, h: float):
    """Exact step of dx/dt = A x + B v(t) with v linear over [0, h]:
    x(h) = Phi x(0) + Gamma0 v(0) + Gamma1 v(h)."""
    n, m = B.shape
    F = np.zeros((n + 2 * m, n + 2 * m))
    F[:n, :n] = A * h
    F[:n, n:n + m] = B * h
    F[n:n + m, n + m:] = np.eye(m)
    E = expm(F)
    Phi = E[:n, :n]
    Q1 = E[:n, n:n + m]      # response to v(0) held
    Q2 = E[:n, n + m:]       # response to the ramp (v(h) - v(0)) t/h
    return Phi, Q1 - Q2, Q2


@dataclass
class Trajectory:
    """The sampled result of a run: one row per communication point t_k = k h."""

    t: np.ndarray
    state_names: tuple[str, ...]
    states: np.ndarray                  # (N+1, n_x) body states
    output_names: tuple[str, ...]       # "corner.output"
    outputs: np.ndarray                 # (N+1, n_y) tire outputs at t_k (end of step k-1)
    input_names: tuple[str, ...]        # "corner.input"
    inputs: np.ndarray                  # (N+1, n_u) coupled tire inputs at t_k
    external_names: tuple[str, ...]
    external: np.ndarray                # (N+1, n_w)
    iterations: np.ndarray = field(repr=False)   # Newton passes per step (2 = trial + final)

    def state(self, name: str) -> np.ndarray:
        return self.states[:, self.state_names.index(name)]

    def output(self, corner: str, name: str) -> np.ndarray:
        return self.outputs[:, self.output_names.index(f"{corner}.{name}")]

    def input(self, corner: str, name: str) -> np.ndarray:
        return self.inputs[:, self.input_names.index(f"{corner}.{name}")]

    def ext(self, name: str) -> np.ndarray:
        return self.external[:, self.external_names.index(name)]

    def columns(self) -> dict[str, np.ndarray]:
        """All signals by name, for a CSV."""
        cols = {"time": self.t}
        for names, values in ((self.external_names, self.external),
                              (self.state_names, self.states),
                              (self.input_names, self.inputs),
                              (self.output_names, self.outputs)):
            for i, n in enumerate(names):
                cols[n] = values[:, i]
        return cols


def _nested(layout: Mapping[str, Sequence[str]], flat: np.ndarray) -> dict[str, dict[str, float]]:
    out, i = {}, 0
    for corner, names in layout.items():
        out[corner] = {n: float(flat[i + j]) for j, n in enumerate(names)}
        i += len(names)
    return out


def _flatten(layout: Mapping[str, Sequence[str]], nested: Mapping[str, Mapping[str, float]],
             what: str) -> np.ndarray:
    values = []
    for corner, names in layout.items():
        given = nested.get(corner, {})
        extra = set(given) - set(names)
        if extra:
            raise KeyError(f"{what} of {corner!r}: {sorted(extra)} not among {list(names)}")
        values.extend(float(given.get(n, 0.0)) for n in names)
    return np.array(values)


class CoSimulation:
    """Steps a vehicle model and its tires with communication step h (see module doc)."""

    def __init__(self, vehicle: VehicleModel, h: float, rtol: float = 1e-10,
                 max_iterations: int = 8):
        if not (h > 0.0 and math.isfinite(h)):
            raise ValueError(f"communication step must be > 0, got {h}")
        self.vehicle = vehicle
        self.h = float(h)
        self.rtol = rtol
        self.max_iterations = max_iterations
        self.corners = tuple(vehicle.tires)
        self.tires = [vehicle.tires[c] for c in self.corners]
        self.in_layout = {c: vehicle.tires[c].input_names for c in self.corners}
        self.out_layout = {c: vehicle.tires[c].output_names for c in self.corners}
        self.input_names = tuple(f"{c}.{n}" for c in self.corners for n in self.in_layout[c])
        self.output_names = tuple(f"{c}.{n}" for c in self.corners for n in self.out_layout[c])
        self._in_slices, self._out_slices = [], []
        i = j = 0
        for c in self.corners:
            self._in_slices.append(slice(i, i + len(self.in_layout[c])))
            self._out_slices.append(slice(j, j + len(self.out_layout[c])))
            i += len(self.in_layout[c])
            j += len(self.out_layout[c])
        fixed = vehicle.fixed_tire_inputs()
        for c, tire in zip(self.corners, self.tires):
            tire.set_inputs(**fixed.get(c, {}))
        self._linearize()
        self.sensitivity = None        # S, measured at the first step

    # ---------------------------------------------------------------- model -> matrices
    def _linearize(self):
        v = self.vehicle
        nx, ny, nw = len(v.state_names), len(self.output_names), len(v.external_names)
        nu = len(self.input_names)
        blocks = [("x", nx), ("y", ny), ("ydot", ny), ("w", nw), ("wdot", nw)]
        n_all = sum(n for _, n in blocks)

        def split(vec):
            parts, i = {}, 0
            for name, n in blocks:
                parts[name] = vec[i:i + n]
                i += n
            return parts

        def f(vec):
            p = split(vec)
            d = v.derivatives(dict(zip(v.state_names, p["x"])), _nested(self.out_layout, p["y"]),
                              _nested(self.out_layout, p["ydot"]),
                              dict(zip(v.external_names, p["w"])),
                              dict(zip(v.external_names, p["wdot"])))
            return np.asarray(d, dtype=float)

        def g(vec):
            p = split(vec)   # (tire inputs do not depend on output rates)
            u = v.tire_inputs(dict(zip(v.state_names, p["x"])), _nested(self.out_layout, p["y"]),
                              dict(zip(v.external_names, p["w"])),
                              dict(zip(v.external_names, p["wdot"])))
            return _flatten(self.in_layout, u, "tire inputs")

        eye = np.eye(n_all)
        F = np.column_stack([f(eye[i]) for i in range(n_all)]) if n_all else np.zeros((nx, 0))
        G = np.column_stack([g(eye[i]) for i in range(n_all)])
        # the equations must be linear: check additivity and zero offset on a random point
        rng = np.random.default_rng(1)
        probe = rng.standard_normal(n_all)
        for fun, M, what in ((f, F, "derivatives"), (g, G, "tire_inputs")):
            if np.any(fun(np.zeros(n_all)) != 0.0):
                raise ValueError(f"{what} has a constant term: the master needs linear equations")
            if not np.allclose(fun(probe), M @ probe, rtol=1e-9, atol=1e-9 * np.abs(M).max()):
                raise ValueError(f"{what} is not linear in its arguments")
        cols = np.cumsum([0] + [n for _, n in blocks])
        part = {name: (cols[i], cols[i + 1]) for i, (name, _) in enumerate(blocks)}

        def block(M, name):
            a, b = part[name]
            return M[:, a:b]

        A, By, Brate = block(F, "x"), block(F, "y"), block(F, "ydot")
        Ew, Ewd = block(F, "w"), block(F, "wdot")
        Cx, Dy, Dw, Dwd = block(G, "x"), block(G, "y"), block(G, "w"), block(G, "wdot")
        # zeta = x - Brate y removes the output rates: dzeta/dt = A zeta + (A Brate + By) y + ...
        self.B_rate = Brate
        Bv = np.hstack([A @ Brate + By, Ew, Ewd])
        Phi, G0, G1 = first_order_hold(A, Bv, self.h)
        self.Phi, self.G0 = Phi, G0
        self.G1_y, self.G1_w, self.G1_wd = G1[:, :ny], G1[:, ny:ny + nw], G1[:, ny + nw:]
        self.C_zeta = Cx
        self.D_y = Cx @ Brate + Dy
        self.D_w, self.D_wd = Dw, Dwd
        # u_end = (terms known at the start of the step) + M_y y_end
        self.M_y = self.C_zeta @ self.G1_y + self.D_y
        self.nx, self.ny, self.nu, self.nw = nx, ny, nu, nw

    # ---------------------------------------------------------------- tire calls
    def _begin(self, u):
        return np.concatenate([t.begin_step(u[s]) for t, s in zip(self.tires, self._in_slices)])

    def _advance(self, u_start, u_end):
        return np.concatenate([t.advance(self.h, u_start[s], u_end[s])
                               for t, s in zip(self.tires, self._in_slices)])

    def _restore(self):
        for t in self.tires:
            t.restore()

    def _measure_sensitivity(self, u_start):
        """S = d y_end / d u_end at the saved state, by probing each input's ramp end.
        Exact for linear tires (outputs are affine in u_end)."""
        base = self._advance(u_start, u_start)
        S = np.zeros((self.ny, self.nu))
        for i in range(self.nu):
            self._restore()
            du = 1.0   # in the input's unit (m/s, rad/s); well inside the FMU's bounds
            u_end = u_start.copy()
            u_end[i] += du
            S[:, i] = (self._advance(u_start, u_end) - base) / du
        self._restore()
        self.sensitivity = S
        self._jacobian_inv = np.linalg.inv(np.eye(self.nu) - self.M_y @ S)

    # ---------------------------------------------------------------- run
    def run(self, external: np.ndarray, x0: Mapping[str, float] | None = None) -> Trajectory:
        """Step through the external-input samples W (N+1 rows, one per communication
        point; one column per ``vehicle.external_names``). x0: initial body state by name
        (default 0). The tires start from their current states."""
        W = np.asarray(external, dtype=float)
        if W.ndim == 1:
            W = W[:, None]
        if W.shape[1] != self.nw:
            raise ValueError(f"external inputs need {self.nw} columns {self.vehicle.external_names}")
        N = W.shape[0] - 1
        h = self.h
        x = np.zeros(self.nx)
        for name, value in (x0 or {}).items():
            x[self.vehicle.state_names.index(name)] = value
        T = np.arange(N + 1) * h
        X = np.empty((N + 1, self.nx))
        Y = np.empty((N + 1, self.ny))
        U = np.empty((N + 1, self.nu))
        iters = np.zeros(N, dtype=np.int32)

        y_prev = self._begin(np.zeros(self.nu))   # coupled inputs start at 0
        zeta = x - self.B_rate @ y_prev
        u_typical = np.zeros(self.nu)
        C_zeta, D_y, D_w, D_wd, M_y = self.C_zeta, self.D_y, self.D_w, self.D_wd, self.M_y
        Phi, G0, G1_y, G1_w, G1_wd = self.Phi, self.G0, self.G1_y, self.G1_w, self.G1_wd
        for k in range(N):
            w0, w1 = W[k], W[k + 1]
            wd = (w1 - w0) / h
            u_start = C_zeta @ zeta + D_y @ y_prev + D_w @ w0 + D_wd @ wd
            y_start = self._begin(u_start)
            # u_start was computed from the outputs before the new inputs were set; that is
            # only consistent if the outputs the tire inputs use have no direct feedthrough
            jump = D_y @ (y_start - y_prev)
            if np.any(np.abs(jump) > 1e-9 * (np.abs(u_start) + u_typical + 1e-300)):
                raise ValueError("the tire inputs depend on a tire output with direct feedthrough "
                                 f"(it jumped by {jump} when the inputs were set); use a state-like "
                                 "output such as a deflection")
            if k == 0:
                X[0] = zeta + self.B_rate @ y_start
                Y[0] = y_start
                U[0] = u_start
            for t in self.tires:
                t.save()
            if self.sensitivity is None:
                self._measure_sensitivity(u_start)
            zeta_known = Phi @ zeta + G0 @ np.concatenate([y_start, w0, wd]) + G1_w @ w1 + G1_wd @ wd
            u_known = C_zeta @ zeta_known + D_w @ w1 + D_wd @ wd
            u_end = u_known + M_y @ y_start            # guess: outputs unchanged over the step
            np.maximum(u_typical, np.abs(u_start), out=u_typical)
            for it in range(self.max_iterations):
                if it:
                    self._restore()
                y_end = self._advance(u_start, u_end)
                residual = u_end - (u_known + M_y @ y_end)
                tol = self.rtol * np.maximum(np.maximum(np.abs(u_end), u_typical), 1e-300)
                if np.all(np.abs(residual) <= tol):
                    break
                if it == 2:   # slow: the tire is not linear here; measure S at this state
                    self._restore()
                    self._measure_sensitivity(u_start)
                u_end = u_end - self._jacobian_inv @ residual
            else:
                raise CouplingError(f"step {k} (t = {T[k]:.6g} s): the tire inputs did not converge "
                                    f"in {self.max_iterations} iterations (residual {residual})")
            iters[k] = it + 1
            zeta = zeta_known + G1_y @ y_end
            y_prev = y_end
            X[k + 1] = zeta + self.B_rate @ y_end
            Y[k + 1] = y_end
            U[k + 1] = u_end
        return Trajectory(T, tuple(self.vehicle.state_names), X, self.output_names, Y,
                          self.input_names, U, tuple(self.vehicle.external_names), W, iters)

    def close(self):
        for t in self.tires:
            t.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
