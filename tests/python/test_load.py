"""Load dependence (docs/specification.md 4b), every model, against its formulas:

* Calpha(Fz) = Calpha x (1 + 1/c2^2)/(1 + x^2/c2^2), x = Fz/Fz0: 1.25 Calpha at 2 Fz0 and
  0.588 Calpha at 0.5 Fz0 for c2 = 2; Ckappa(Fz) = Ckappa x; reached in steady state;
* the stiffnesses stay: the standstill stiffness is C_y = Calpha/sigmaY at any load;
* the relaxation lengths scale: RLT's lateral lag has the time constant sigmaY(Fz)/|vx|;
* at Fz = Fz0 everything is the nominal model; until Fz is set it follows Fz0.
"""

import numpy as np
import pytest

import reference as ref

LOAD_RATIOS = [0.5, 1.0, 2.0, 3.0]


def _rel(a, b):
    return abs(a - b) / abs(b)


def test_cornering_stiffness_law_has_the_documented_values():
    p = ref.parameters()
    assert p["calphaLoadPeak"] == 2.0
    assert _rel(ref.cornering_stiffness_at(p, 2 * p["Fz0"]), 1.25 * p["Calpha"]) < 1e-15
    assert abs(ref.cornering_stiffness_at(p, 0.5 * p["Fz0"]) / p["Calpha"] - 0.588) < 5e-4
    assert ref.cornering_stiffness_at(p, p["Fz0"]) == p["Calpha"]


@pytest.mark.parametrize("ratio", LOAD_RATIOS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_steady_state_follows_the_loaded_slip_stiffnesses(make_tire, model, ratio):
    p = ref.parameters()
    Fz = ratio * p["Fz0"]
    vx, vy, vsx = 5.0, -0.2, 0.1
    alpha, kappa = -vy / vx, -vsx / vx
    tire = make_tire(model, vx=vx, Fz=Fz)
    y = dict(zip(ref.OUTPUTS, tire.run(np.tile([vy, 0.0, vsx], (4, 1)), 10.0)[-1]))
    assert _rel(y["Fy"], ref.cornering_stiffness_at(p, Fz) * alpha) < 1e-9, y["Fy"]
    assert _rel(y["Fx"], p["Ckappa"] * ratio * kappa) < 1e-9, y["Fx"]
    # the transient slips use the loaded lengths, so they equal the slips in steady state
    assert _rel(y["alphaT"], alpha) < 1e-9 and _rel(y["kappaT"], kappa) < 1e-9


@pytest.mark.parametrize("ratio", LOAD_RATIOS)
@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_standstill_stiffness_is_independent_of_the_load(make_tire, model, ratio):
    """vx = 0: push 2 mm sideways, hold until settled: Fy = -C_y * 2 mm at every load."""
    p = ref.parameters()
    tire = make_tire(model, vx=0.0, Fz=ratio * p["Fz0"])
    tire.run(np.array([[0.02, 0.0, 0.0]]), 0.1)
    y = dict(zip(ref.OUTPUTS, tire.run(np.zeros((1, 3)), 100.0)[-1]))
    assert _rel(y["Fy"], -p["Calpha"] / p["sigmaY"] * 0.002) < 1e-9, y["Fy"]


@pytest.mark.parametrize("ratio", LOAD_RATIOS)
def test_rlt_lateral_time_constant_is_the_loaded_relaxation_length_over_speed(make_tire, ratio):
    p = ref.parameters()
    Fz = ratio * p["Fz0"]
    vx, vy = 8.0, -0.3
    sigma = p["sigmaY"] * ref.cornering_stiffness_at(p, Fz) / p["Calpha"]
    tau = sigma / vx
    tire = make_tire("RLT", vx=vx, Fz=Fz)
    t = np.array([0.25, 0.5, 1.0]) * tau
    fy = [tire.run(np.array([[vy, 0.0, 0.0]]), float(h))[-1][ref.OUT["Fy"]] for h in np.diff(t, prepend=0.0)]
    final = ref.cornering_stiffness_at(p, Fz) * (-vy / vx)
    expected = final * (1.0 - np.exp(-t / tau))
    assert np.all(np.abs(np.array(fy) - expected) <= 1e-9 * abs(final)), (fy, expected)


@pytest.mark.parametrize("model", ref.MODEL_NAMES)
def test_an_unset_load_follows_the_nominal_load(make_tire, model):
    """Fz starts at Fz0 (docs/specification.md 3): a tire with another Fz0 and no Fz set runs at x = 1."""
    params = {"Fz0": 30000.0}
    p = ref.parameters(**params)
    tire = make_tire(model, params=params, vx=5.0)
    assert tire.fmu.getReal([ref.INPUT_VR["Fz"]]) == [30000.0]
    y = dict(zip(ref.OUTPUTS, tire.run(np.tile([-0.2, 0.0, 0.1], (4, 1)), 10.0)[-1]))
    assert _rel(y["Fy"], p["Calpha"] * 0.04) < 1e-9, y["Fy"]
