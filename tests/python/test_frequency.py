"""Frequency responses of every model against docs/specification.md 5 (0.05 dB, 0.2 degrees).

Sinusoidal inputs are ramped between samples h = period/200 apart with input derivatives
(exact for the piecewise-linear input). Linear interpolation scales the fundamental of a
sampled sinusoid by exactly sinc^2(omega h/2) (about 1e-4 here); the expected values carry
that factor. The measured phasor comes from a least-squares fit of a cubic trend + cos +
sin over two whole periods after the transients have settled.

Transfer functions (docs/specification.md 5 and the output equations of 4):
  Fy/vy = -Z,                 Mz/vy = trail Z,
  DDT:  Fy/r = -Z vx/(s + rho/sigmaPsi),
        Mz/r = -(stiffnessPsi + dampingPsi s)/(s + rho/sigmaPsi) - trail Fy/r,
  Fx/vsx = -Zx, My/vsx = Re Zx (RLT, DDT, SecondOrder: My = -Re Fx),
  RingBody circumferential: Fx/vsx and My/vsx as given in docs/specification.md 5.
"""

import math

import numpy as np
import pytest

import harness
import reference as ref
from conftest import seed

SPEEDS = [0.0, 0.45, 1.6, 20.0, -5.0]
FREQS = np.geomspace(0.05, 20.0, 6)
GAIN_DB = 0.05
PHASE_DEG = 0.2
AMP = {"vy": 0.1, "steerRate": 0.05, "vsx": 0.1}


def _check(measured, expected, label, failures):
    dg, dph = harness.gain_phase_error(measured, expected)
    if not (abs(dg) <= GAIN_DB and abs(dph) <= PHASE_DEG):
        failures.append(f"{label}: gain error {dg:+.4f} dB, phase error {dph:+.4f} deg "
                        f"(measured |G| {abs(measured):.6g} angle {math.degrees(np.angle(measured)):.3f}, "
                        f"docs/specification.md 5: |G| {abs(expected):.6g} angle {math.degrees(np.angle(expected)):.3f})")


@pytest.mark.parametrize("vx", SPEEDS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_lateral_and_longitudinal_frequency_response(make_tire, model, vx):
    """Fy/vy, Mz/vy (lateral) and Fx/vsx, My/vsx (longitudinal), driven together."""
    p = ref.parameters()
    failures = []
    for f in FREQS:
        tire = make_tire(model, vx=vx)
        P, corr, _, _ = harness.frequency_response(tire, model, p, vx, f,
                                                   {"vy": AMP["vy"], "vsx": AMP["vsx"]})
        tf = ref.transfer(model, p, vx, 1j * math.tau * f)
        for out, inp in (("Fy", "vy"), ("Mz", "vy"), ("Fx", "vsx"), ("My", "vsx")):
            _check(P[out] / AMP[inp], corr * tf[f"{out}/{inp}"],
                   f"{model} vx={vx} f={f:.3g} Hz {out}/{inp}", failures)
        assert abs(P["deflPsi"]) == 0.0, "no yaw deflection without steering"
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("vx", SPEEDS)
def test_ddt_steering_frequency_response(make_tire, vx):
    """DDT: Fy/steerRate = -Z vx/(s + rho/sigmaPsi) and Mz/steerRate."""
    model = "DDT"
    p = ref.parameters()
    failures = []
    for f in FREQS:
        tire = make_tire(model, vx=vx)
        P, corr, Yw, _ = harness.frequency_response(tire, model, p, vx, f, {"steerRate": AMP["steerRate"]})
        tf = ref.transfer(model, p, vx, 1j * math.tau * f)
        label = f"DDT vx={vx} f={f:.3g} Hz"
        _check(P["Mz"] / AMP["steerRate"], corr * tf["Mz/steerRate"], label + " Mz/steerRate", failures)
        if vx == 0.0:
            # at standstill steering does not load the tire sideways (vx uPsi = 0)
            assert np.max(np.abs(Yw[:, ref.OUT["Fy"]])) <= 1e-9 * np.max(np.abs(Yw[:, ref.OUT["Mz"]])), \
                f"{label}: Fy must be zero at vx = 0, max |Fy| {np.max(np.abs(Yw[:, ref.OUT['Fy']]))}"
        else:
            _check(P["Fy"] / AMP["steerRate"], corr * tf["Fy/steerRate"], label + " Fy/steerRate", failures)
        # the yaw deflection lags the steer angle: uPsi/r = 1/(s + rho/sigmaPsi)
        _check(P["deflPsi"] / AMP["steerRate"], corr / (1j * math.tau * f + abs(vx) / p["sigmaPsi"]),
               label + " deflPsi/steerRate", failures)
        # no longitudinal response to steering
        assert np.all(Yw[:, [ref.OUT["Fx"], ref.OUT["My"], ref.OUT["deflX"]]] == 0.0)
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("vx", SPEEDS)
@pytest.mark.parametrize("model", ["RLT", "SecondOrder", "RingBody"])
def test_no_steering_path_outside_ddt(make_tire, model, vx):
    """Only DDT has a steerRate path: for the others every output stays exactly zero."""
    rng = np.random.default_rng(seed(model, vx))
    n = 200
    U = np.zeros((n, 3))
    U[:, 1] = rng.uniform(-1.0, 1.0, size=n)
    dU = np.zeros((n, 3))
    dU[:, 1] = rng.uniform(-5.0, 5.0, size=n)
    tire = make_tire(model, vx=vx)
    Y = tire.run(U, 0.01, dU=dU)
    assert np.all(Y == 0.0), f"{model}: steerRate changed outputs: max {np.max(np.abs(Y), axis=0)}"


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_reference_transfer_functions_match_state_space(model):
    """Self-check of the test reference: the docs/specification.md 5 formulas equal
    C (sI - A)^-1 B + D of the section 4 equations (two independent derivations)."""
    p = ref.parameters()
    s = 1j * math.tau * FREQS
    pairs = {"Fy/vy": ("Fy", "vy"), "Fy/steerRate": ("Fy", "steerRate"), "Mz/vy": ("Mz", "vy"),
             "Mz/steerRate": ("Mz", "steerRate"), "Fx/vsx": ("Fx", "vsx"), "My/vsx": ("My", "vsx")}
    for vx in SPEEDS:
        G = ref.state_space_response(model, p, vx, s)
        tf = ref.transfer(model, p, vx, s)
        for key, (o, i) in pairs.items():
            g = G[:, ref.OUT[o], ref.DRIVING.index(i)]
            assert np.allclose(g, tf[key], rtol=1e-10, atol=1e-10 * np.max(np.abs(G))), (model, vx, key)
