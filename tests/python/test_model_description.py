"""The packed modelDescription.xml against docs/specification.md 1, 3 and 7."""

import zipfile

import numpy as np
import pytest

import reference as ref

INPUT_UNITS = {"vx": "m/s", "vy": "m/s", "steerRate": "rad/s", "vsx": "m/s", "Fz": "N"}
OUTPUT_UNITS = {"Fx": "N", "Fy": "N", "Mz": "N.m", "My": "N.m", "alphaT": "rad", "kappaT": "1",
                "deflX": "m", "deflY": "m", "deflPsi": "rad"}
PARAMETER_UNITS = {
    "Calpha": "N/rad", "Ckappa": "N", "sigmaY": "m", "sigmaX": "m", "Re": "m", "trail": "m",
    "Fz0": "N", "dampingY": "N.s/m", "dampingX": "N.s/m", "sigmaPsi": "m",
    "stiffnessPsi": "N.m/rad", "dampingPsi": "N.m.s/rad", "contactMass": "kg",
    "carcassDampingY": "N.s/m", "ringMass": "kg", "ringInertia": "kg.m2",
    "ringDampingY": "N.s/m", "ringDampingX": "N.s/m", "sigmaTread": "m",
    "calphaLoadPeak": "1", "muX": "1", "muY": "1", "muLoadSensitivity": "1", "boreRadius": "m",
}


@pytest.fixture(scope="module")
def variables(model_description):
    return {v.name: v for v in model_description.modelVariables}


def test_fmu_validates(fmu_path):
    from fmpy.validation import validate_fmu

    problems = validate_fmu(fmu_path)
    assert problems == [], "\n".join(problems)


def test_archive_layout(fmu_path):
    names = zipfile.ZipFile(fmu_path).namelist()
    assert "modelDescription.xml" in names
    assert "binaries/linux64/TireLag.so" in names


def test_packed_description_is_the_single_source(fmu_path, model_description):
    """docs/specification.md 1: modelDescription/ is the one source of truth; the FMU carries it."""
    from fmpy import read_model_description

    from conftest import REPO

    source = read_model_description(str(REPO / "modelDescription" / "modelDescription.xml"))
    assert source.guid == model_description.guid
    assert [(v.name, v.valueReference, v.causality, v.variability, v.unit, v.start)
            for v in source.modelVariables] == \
           [(v.name, v.valueReference, v.causality, v.variability, v.unit, v.start)
            for v in model_description.modelVariables]


def test_cosimulation_capabilities(model_description):
    md = model_description
    assert md.fmiVersion == "2.0"
    cs = md.coSimulation
    assert cs is not None and cs.modelIdentifier == "TireLag"
    assert cs.canHandleVariableCommunicationStepSize
    assert cs.canGetAndSetFMUstate
    assert cs.canSerializeFMUstate
    assert cs.canInterpolateInputs
    assert cs.maxOutputDerivativeOrder == 1
    assert cs.providesDirectionalDerivative
    assert md.guid


def test_model_exchange_capabilities(model_description):
    """docs/specification.md 7b: Model Exchange beside Co-Simulation, same modelIdentifier, with FMU state,
    serialization and directional derivatives; 18 states and 9 event indicators."""
    md = model_description
    me = md.modelExchange
    assert me is not None and me.modelIdentifier == md.coSimulation.modelIdentifier
    assert me.canGetAndSetFMUstate and me.canSerializeFMUstate
    assert me.providesDirectionalDerivative
    assert md.numberOfEventIndicators == 9
    assert len(md.derivatives) == 18


def test_inputs(variables):
    for name, unit in INPUT_UNITS.items():
        v = variables[name]
        assert v.causality == "input" and v.variability == "continuous" and v.type == "Real", name
        assert v.unit == unit, (name, v.unit)
        assert v.valueReference == ref.INPUT_VR[name]
        expected_start = ref.DEFAULTS["Fz0"] if name == "Fz" else 0.0
        assert float(v.start) == expected_start, (name, v.start)


def test_outputs(variables):
    for name, unit in OUTPUT_UNITS.items():
        v = variables[name]
        assert v.causality == "output" and v.variability == "continuous" and v.type == "Real", name
        assert v.unit == unit, (name, v.unit)
        assert v.valueReference == ref.OUTPUT_VR[name]


# The friction parameters (docs/specification.md 3, 4c) and their documented defaults.
FRICTION_PARAMETERS = {"muX": (122, 0.8), "muY": (123, 0.8), "muLoadSensitivity": (124, -0.1),
                       "boreRadius": (125, 0.1)}


def test_parameters(variables):
    for name, unit in PARAMETER_UNITS.items():
        v = variables[name]
        assert v.causality == "parameter" and v.variability == "fixed" and v.type == "Real", name
        assert v.unit == unit, (name, v.unit)
        vr, default = FRICTION_PARAMETERS.get(name) or (ref.PARAMETER_VR[name], ref.DEFAULTS[name])
        assert v.valueReference == vr
        assert float(v.start) == default, (name, v.start)
    # friction coefficients and the bore radius are never negative; the load sensitivity
    # may be (mu(Fz) is floored at 0)
    for name in ("muX", "muY", "boreRadius"):
        assert float(variables[name].min) == 0.0, name
    assert variables["muLoadSensitivity"].min is None
    # snowblower values where Koo & Tan Table 1 gives them (docs/specification.md 3, 9)
    for name, value in ref.SNOWBLOWER.items():
        assert float(variables[name].start) == value, name
    # sigmaTread below sigmaY and sigmaX (docs/specification.md 3)
    st = float(variables["sigmaTread"].start)
    assert 0 < st < float(variables["sigmaY"].start) and st < float(variables["sigmaX"].start)


def test_friction_selector_is_an_integer_every_importer_can_set(model_description, variables):
    v = variables["friction"]
    assert (v.type, v.causality, v.variability, v.valueReference) == ("Integer", "parameter", "fixed", 121)
    assert (int(v.start), int(v.min), int(v.max)) == (3, 1, 3), "Brush by default"
    assert v.declaredType.name == "TireFriction"
    assert "1 = Unlimited" in v.description and "2 = Coulomb" in v.description and "3 = Brush" in v.description


def test_tire_model_selector_is_an_integer_every_importer_can_set(variables):
    # Integer, not Enumeration: OSP libcosim ignores Enumeration variables (docs/specification.md 3).
    v = variables["tireModel"]
    assert v.causality == "parameter" and v.variability == "fixed"
    assert v.type == "Integer"
    assert v.declaredType is not None and v.declaredType.name == "TireLagModel"
    assert (int(v.min), int(v.max)) == (1, 4)
    assert int(v.start) == ref.MODELS["DDT"]
    assert v.valueReference == ref.MODEL_VR
    # The names stand in the description, with their values.
    for name, value in ref.MODELS.items():
        assert f"{value} = {name}" in v.description, (name, v.description)


# Modelica 3 keywords (Modelica Language Specification 3.6, section 2.3.3). A Modelica tool
# declares one Modelica variable per FMU variable, so none of them may be a variable name.
MODELICA_KEYWORDS = set("""
    algorithm and annotation block break class connect connector constant constrainedby der
    discrete each else elseif elsewhen encapsulated end enumeration equation expandable extends
    external false final flow for function if import impure in initial inner input loop model not
    operator or outer output package parameter partial protected public pure record redeclare
    replaceable return stream then true type when while within
""".split())


def test_no_variable_is_named_after_a_modelica_keyword(variables):
    clashes = sorted(set(variables) & MODELICA_KEYWORDS)
    assert not clashes, f"variables named after Modelica keywords: {clashes}"
    assert "model" in MODELICA_KEYWORDS and "tireModel" not in MODELICA_KEYWORDS


def test_no_other_variables(variables):
    # Model Exchange: the model's states in six slots, the branch offsets by direction
    # and branch, their derivatives, and the event indicators; the independent variable.
    states = {f"tireState{k}" for k in range(1, 7)}
    states |= {f"sliderOffset{d}{i}" for d in ("X", "Y", "Psi") for i in range(1, 5)}
    guards = {f"guard{g}{i}" for g in ("Planar", "Yaw") for i in range(1, 5)} | {"guardLoad"}
    expected = set(INPUT_UNITS) | set(OUTPUT_UNITS) | set(PARAMETER_UNITS) | {"tireModel", "friction"}
    expected |= states | {f"der({s})" for s in states} | {"tirFile", "time"} | guards
    assert set(variables) == expected
    vrs = [v.valueReference for v in variables.values()]
    assert len(vrs) == len(set(vrs)), "value references must be unique"


def test_units_are_defined(model_description, variables):
    defined = {u.name for u in model_description.unitDefinitions}
    used = {v.unit for v in variables.values() if v.unit}
    assert used <= defined, used - defined


def _true_dependencies():
    """Inputs that each output depends on directly, from the equations of docs/specification.md 4 (union over
    the four models): D != 0, C depends on vx, and on Fz (lift-off, loaded lengths)."""
    rng = np.random.default_rng(1)
    deps = {o: set() for o in ref.OUTPUTS}
    p = ref.parameters()
    for model in ref.MODEL_NAMES:
        n = len(ref.STATES[model])
        x = rng.normal(size=n)
        u = rng.normal(size=3)
        ys = {}
        for vx in (-3.0, 2.0, 5.0):
            A, B, C, D = ref.system(model, p, vx)
            ys[vx] = C @ x + D @ u
            for j, o in enumerate(ref.OUTPUTS):
                for i, name in enumerate(ref.DRIVING):
                    if D[j, i] != 0.0:
                        deps[o].add(name)
        _, _, Cl, Dl = ref.system(model, p, 2.0, lifted_off=True)
        _, _, Ch, Dh = ref.system(model, p, 2.0, Fz=1.5 * p["Fz0"])
        y_lifted, y_heavy = Cl @ x + Dl @ u, Ch @ x + Dh @ u
        for j, o in enumerate(ref.OUTPUTS):
            if len({round(ys[v][j], 12) for v in ys}) > 1:
                deps[o].add("vx")
            if y_lifted[j] != ys[2.0][j] or abs(y_heavy[j] - ys[2.0][j]) > 1e-12 * abs(ys[2.0][j]):
                deps[o].add("Fz")
    # Friction (docs/specification.md 4c): DDT's damped forces depend on the slip velocities directly; where
    # both directions slide together on the ellipse, each force depends on both.
    for o in ("Fx", "Fy", "Mz", "My"):
        deps[o] |= {"vy", "vsx", "Fz"}
    return deps


def test_model_structure_outputs(model_description):
    outs = model_description.outputs
    names = [u.variable.name for u in outs]
    assert len(names) == 9 and sorted(names) == sorted(ref.OUTPUTS), names
    truth = _true_dependencies()
    # Model Exchange: every output also depends on the continuous states.
    states = {v.name for v in model_description.modelVariables if v.name.startswith(("tireState", "sliderOffset"))}
    assert len(states) == 18
    for u in outs:
        declared = {d.name for d in u.dependencies} - states
        assert {d.name for d in u.dependencies} >= states, u.variable.name
        assert declared == truth[u.variable.name], (
            f"{u.variable.name}: declared direct dependencies {sorted(declared)}, "
            f"the equations of docs/specification.md give {sorted(truth[u.variable.name])}")
    # sanity of the derivation itself
    assert truth["Fy"] >= {"vy"} and truth["Mz"] >= {"vy", "steerRate"} and truth["deflY"] == set()


def test_initial_unknowns_cover_outputs(model_description):
    names = {u.variable.name for u in model_description.initialUnknowns}
    assert set(ref.OUTPUTS) <= names
