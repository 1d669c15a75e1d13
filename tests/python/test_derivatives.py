"""Derivatives at the FMI interface (docs/specification.md 6 and 7):

* fmi2GetDirectionalDerivative: exact d outputs / d inputs at the current state, checked
  against central finite differences of fmi2GetReal (outputs are direct functions of the
  inputs at a fixed state, so no stepping is needed);
* fmi2GetRealOutputDerivatives: exact d outputs / dt, checked against a 6th-order central
  difference in time built from tiny communication steps;
* fmi2SetRealInputDerivatives: a ramped input over one long step is exact: it equals 500
  short steps of the same ramp and an independent matrix-exponential solution of RLT.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy.linalg import expm

import fmi4_common as fc

MODELS = list(fc.MODELS)
SPEEDS = [0.0, 1.6, 20.0]


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    return fc.module_fmu(tmp_path_factory, "fmi4_deriv")


@pytest.fixture(scope="module")
def starts(fmu):
    return fc.start_values(fmu[0])


@pytest.fixture
def slaves(fmu):
    """Instances of the linear models (friction Unlimited): the derivatives here are
    checked against the linear model's matrices. test_friction.py checks them with limits."""
    with fc.slave_factory(*fmu, "d") as new:
        yield functools.partial(new, friction="Unlimited")


def warmed_up(slaves, model, vx, n=50, h=0.01):
    """An instance with nonzero states: n steps with nonzero driving inputs at speed vx."""
    s = slaves(model, inputs=dict(vx=vx, vy=0.2, steerRate=0.15, vsx=0.1))
    t = 0.0
    for _ in range(n):
        s.doStep(t, h)
        t += h
    return s, t


# --------------------------------------------------------------------------- directional

@pytest.mark.parametrize("vx", SPEEDS)
@pytest.mark.parametrize("model", MODELS)
def test_directional_derivatives_match_central_differences(slaves, model, vx):
    s, _ = warmed_up(slaves, model, vx)
    u = {"vx": vx, "vy": -0.23, "steerRate": -0.11, "vsx": 0.17, "Fz": 47000.0}
    s.setReal(fc.IN_VRS, list(u.values()))
    y0 = fc.outputs(s)
    J = np.empty((9, 5))
    bad = []
    for j, name in enumerate(fc.INPUTS):
        vr = fc.INPUT_VR[name]
        dd = np.array(s.getDirectionalDerivative(fc.OUT_VRS, [vr], [1.0]))
        J[:, j] = dd
        du = 1e-6 * max(1.0, abs(u[name]))
        s.setReal([vr], [u[name] + du])
        yp = fc.outputs(s)
        s.setReal([vr], [u[name] - du])
        ym = fc.outputs(s)
        s.setReal([vr], [u[name]])
        fd = (yp - ym) / (2.0 * du)
        scale = np.maximum(np.maximum(np.abs(fd), np.abs(dd)), 1.0)
        for i in np.nonzero(np.abs(fd - dd) > 1e-6 * scale)[0]:
            bad.append(f"d{fc.OUTPUTS[i]}/d{name}: directional {dd[i]:.12e}, central difference {fd[i]:.12e}")
    assert not bad, f"{model} vx={vx}:\n  " + "\n  ".join(bad)
    # reading derivatives changed nothing
    assert np.array_equal(fc.outputs(s), y0)
    # a combined seed is the linear combination of the columns
    seed = np.array([0.3, -1.2, 0.7, 2.0, -0.5])
    comb = np.array(s.getDirectionalDerivative(fc.OUT_VRS, fc.IN_VRS, list(seed)))
    np.testing.assert_allclose(comb, J @ seed, rtol=1e-12, atol=1e-9 * max(1.0, np.abs(J).max()))
    # unknowns in another order and a subset
    sub = [fc.OUTPUT_VR["deflY"], fc.OUTPUT_VR["Fy"]]
    d_sub = s.getDirectionalDerivative(sub, [fc.INPUT_VR["vy"]], [1.0])
    assert d_sub == [J[fc.OUTPUTS.index("deflY"), 1], J[fc.OUTPUTS.index("Fy"), 1]]
    if model != "RLT":
        # these models have direct feedthrough from vy to Fy (damping): not a zero test
        assert J[fc.OUTPUTS.index("Fy"), 1] != 0.0


@pytest.mark.parametrize("model", MODELS)
def test_directional_derivatives_equal_feedthrough_matrix(slaves, starts, model):
    """d outputs / d (vy, steerRate, vsx) is the D matrix of docs/specification.md 4, whatever the
    state: written out here from the equations."""
    s, _ = warmed_up(slaves, model, 7.0)
    J = np.array([s.getDirectionalDerivative(fc.OUT_VRS, [vr], [1.0]) for vr in fc.DRIVING_VRS]).T
    p = {k: starts[k] for k in fc.PARAMETER_VR}
    D = np.zeros((9, 3))
    o = {n: i for i, n in enumerate(fc.OUTPUTS)}
    if model == "DDT":
        D[o["Fy"], 0] = -p["dampingY"]
        D[o["Fx"], 2] = -p["dampingX"]
        D[o["Mz"], 1] = -p["dampingPsi"]
        D[o["Mz"], 0] = -p["trail"] * D[o["Fy"], 0]
        D[o["My"], 2] = -p["Re"] * D[o["Fx"], 2]
    elif model in ("SecondOrder", "RingBody"):
        d = p["carcassDampingY"] if model == "SecondOrder" else p["ringDampingY"]
        D[o["Fy"], 0] = -d                      # Fy = k eta + d (w - vy)
        D[o["Mz"], 0] = p["trail"] * d
        if model == "RingBody":
            D[o["My"], 2] = p["Re"] * p["ringDampingX"]   # My = -Re (k_x xr + dx (wx - vsx))
    np.testing.assert_allclose(J, D, rtol=1e-12, atol=1e-12)


def test_directional_derivative_wrt_vx_at_zero_speed_is_the_central_difference(slaves):
    """d|vx|/dvx is taken as 0 at vx = 0; only the terms linear in vx remain (DDT: vx uPsi)."""
    s, _ = warmed_up(slaves, "DDT", 0.0)
    d = s.getDirectionalDerivative([fc.OUTPUT_VR["Fy"]], [fc.INPUT_VR["vx"]], [1.0])[0]
    uPsi = s.getReal([fc.OUTPUT_VR["deflPsi"]])[0]
    dampingY = s.getReal([fc.PARAMETER_VR["dampingY"]])[0]
    assert uPsi != 0.0
    # Fy = -(C_y uY + D_y (vy + vx uPsi - |vx|/sigmaY uY)) => dFy/dvx = -D_y uPsi at vx = 0
    assert d == pytest.approx(-dampingY * uPsi, rel=1e-12)


# --------------------------------------------------------------------------- output derivatives

# 7-point central difference for the first derivative (error h^6 y^(7) / 140)
STENCIL = np.array([-1.0, 9.0, -45.0, 0.0, 45.0, -9.0, 1.0]) / 60.0


@pytest.mark.parametrize("ramped", [False, True], ids=["held", "ramped"])
@pytest.mark.parametrize("vx", SPEEDS)
@pytest.mark.parametrize("model", MODELS)
def test_output_derivatives_match_difference_in_time(slaves, model, vx, ramped):
    """At constant vx, after a jump of the driving inputs (so the states are far from
    steady), d outputs/dt from fmi2GetRealOutputDerivatives equals a central difference of
    outputs at t - 3h .. t + 3h (h = 0.1 ms). With ramped inputs the derivative includes
    the feedthrough of the input rates (set again at the communication point)."""
    s, t = warmed_up(slaves, model, vx)
    u0 = np.array([-0.23, -0.11, 0.17])
    r = np.array([3.0, -2.0, 1.5]) if ramped else np.zeros(3)
    h = 1e-4
    Y = []
    for k in range(7):
        s.setReal(fc.DRIVING_VRS, list(u0 + r * (k * h)))
        s.setRealInputDerivatives(fc.DRIVING_VRS, [1, 1, 1], list(r))
        Y.append(fc.outputs(s))
        if k == 3:
            dd = np.array(s.getRealOutputDerivatives(fc.OUT_VRS, [1] * 9))
        if k < 6:
            s.doStep(t, h)
            t += h
    Y = np.array(Y)
    fd = STENCIL @ Y / h
    # noise floor of the difference: ~ 1e-13 |y| / h
    tol = 1e-6 * np.maximum(np.maximum(np.abs(fd), np.abs(dd)), 1.0) + 1e-13 * np.abs(Y).max(0) / h
    bad = np.nonzero(np.abs(fd - dd) > tol)[0]
    assert bad.size == 0, "\n".join(
        f"d{fc.OUTPUTS[i]}/dt: FMU {dd[i]:.12e}, difference {fd[i]:.12e}" for i in bad)
    assert np.any(dd != 0.0)


# --------------------------------------------------------------------------- input derivatives

def _ramp_fine(s, t, u0, r, T, n):
    """n steps of T/n with u(t) = u0 + r (t - t0) set at every step and the rate r."""
    h = T / n
    Y = np.empty((n, 9))
    for k in range(n):
        s.setReal(fc.DRIVING_VRS, list(u0 + r * (k * h)))
        s.setRealInputDerivatives(fc.DRIVING_VRS, [1, 1, 1], list(r))
        s.doStep(t, h)
        t += h
        Y[k] = fc.outputs(s)
    return Y, t


@pytest.mark.parametrize("vx", SPEEDS + [-5.0])
@pytest.mark.parametrize("model", MODELS)
def test_ramped_long_step_equals_fine_steps(slaves, model, vx):
    s, t = warmed_up(slaves, model, vx)
    state = s.getFMUstate()
    u0 = np.array([0.31, -0.2, -0.12])
    r = np.array([-1.1, 0.8, 0.6])
    T = 0.5
    s.setReal(fc.DRIVING_VRS, list(u0))
    s.setRealInputDerivatives(fc.DRIVING_VRS, [1, 1, 1], list(r))
    s.doStep(t, T)
    y_long = fc.outputs(s)
    s.setFMUstate(state)
    s.freeFMUstate(state)
    Y, _ = _ramp_fine(s, t, u0, r, T, 500)
    y_fine = Y[-1]
    scale = np.abs(Y).max(0)
    err = np.abs(y_long - y_fine)
    bad = np.nonzero(err > 1e-9 * scale + 1e-12)[0]
    assert bad.size == 0, "\n".join(
        f"{fc.OUTPUTS[i]}: one 0.5 s step {y_long[i]:.15e}, 500 x 1 ms {y_fine[i]:.15e} "
        f"(rel {err[i] / max(scale[i], 1e-300):.2e})" for i in bad)
    assert np.any(y_long != 0.0)


def _rlt_exact(p, vx, x0, u0, r, T):
    """Independent RLT solution: duY/dt = vy - (rho/sigmaY) uY, duX/dt = vsx - (rho/sigmaX) uX
    with vy = vy0 + r_y t, vsx = vsx0 + r_x t; augmented state [uY, uX, vy, vsx, r_y, r_x]."""
    rho = abs(vx)
    M = np.zeros((6, 6))
    M[0, 0] = -rho / p["sigmaY"]
    M[1, 1] = -rho / p["sigmaX"]
    M[0, 2] = 1.0
    M[1, 3] = 1.0
    M[2, 4] = 1.0
    M[3, 5] = 1.0
    z = expm(M * T) @ np.array([x0[0], x0[1], u0[0], u0[2], r[0], r[2]])
    uY, uX = z[0], z[1]
    Fy = -(p["Calpha"] / p["sigmaY"]) * uY
    Fx = -(p["Ckappa"] / p["sigmaX"]) * uX
    return {"Fx": Fx, "Fy": Fy, "Mz": -p["trail"] * Fy, "My": -p["Re"] * Fx,
            "alphaT": -uY / p["sigmaY"], "kappaT": -uX / p["sigmaX"],
            "deflX": uX, "deflY": uY, "deflPsi": 0.0}


@pytest.mark.parametrize("T", [0.5, 1e-3, 7.0])
@pytest.mark.parametrize("vx", SPEEDS + [-5.0])
def test_ramped_step_rlt_matches_independent_expm(slaves, starts, vx, T):
    params = {"sigmaY": 0.7, "sigmaX": 0.35, "Calpha": 2.6e5, "Ckappa": 4.1e5, "trail": 0.03, "Re": 0.45}
    s = slaves("RLT", params, inputs=dict(vx=vx, vy=0.2, steerRate=0.15, vsx=0.1))
    t = 0.0
    for _ in range(40):
        s.doStep(t, 0.01)
        t += 0.01
    p = {k: starts[k] for k in fc.PARAMETER_VR}
    p.update(params)
    x0 = s.getReal([fc.OUTPUT_VR["deflY"], fc.OUTPUT_VR["deflX"]])
    assert x0[0] != 0.0 and x0[1] != 0.0
    u0 = np.array([0.31, -0.2, -0.12])
    r = np.array([-1.1, 0.8, 0.6])
    s.setReal(fc.DRIVING_VRS, list(u0))
    s.setRealInputDerivatives(fc.DRIVING_VRS, [1, 1, 1], list(r))
    s.doStep(t, T)
    y = dict(zip(fc.OUTPUTS, fc.outputs(s)))
    ref = _rlt_exact(p, vx, x0, u0, r, T)
    bad = [f"{k}: FMU {y[k]:.15e}, expm {ref[k]:.15e}" for k in fc.OUTPUTS
           if abs(y[k] - ref[k]) > 1e-9 * max(abs(ref[k]), abs(y[k])) + 1e-15]
    assert not bad, f"vx={vx} T={T}:\n  " + "\n  ".join(bad)
