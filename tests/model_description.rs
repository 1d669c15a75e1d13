//! The model description is the one source of truth: these tests read the XML on their
//! own and prove that the generated table, the physics and the ModelStructure agree.

use std::collections::BTreeMap;

use quick_xml::Reader;
use quick_xml::events::Event;
use tirelag::fmi::instance::start_parameters;
use tirelag::fmi::variables::{
    CONTINUOUS_STATE_VARIABLES, Causality, DERIVATIVE_VARIABLES, EVENT_INDICATOR_VARIABLES,
    FMI3_MODEL_DESCRIPTION_XML, GUID, Role, VARIABLES, ValueType, Variable,
};
use tirelag::physics::tire::hybrid::{CONTINUOUS_STATES, GUARDS};
use tirelag::physics::{Input, Output, Parameter, Parameters};

const XML: &str = include_str!("../modelDescription/modelDescription.xml");

/// (element name, attributes) of every element, in document order.
fn elements() -> Vec<(String, BTreeMap<String, String>)> {
    elements_of(XML)
}

fn elements_of(xml: &str) -> Vec<(String, BTreeMap<String, String>)> {
    let mut reader = Reader::from_str(xml);
    let mut out = Vec::new();
    loop {
        match reader.read_event().unwrap() {
            Event::Start(e) | Event::Empty(e) => {
                let attributes = e
                    .attributes()
                    .map(|a| {
                        let a = a.unwrap();
                        let key = a.key.as_ref().to_owned();
                        let value = a
                            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                            .unwrap()
                            .into_owned();
                        (key, value)
                    })
                    .collect();
                out.push((e.name().as_ref().to_owned(), attributes));
            }
            Event::Eof => break,
            _ => {}
        }
    }
    out
}

fn scalar_variables() -> Vec<BTreeMap<String, String>> {
    elements()
        .into_iter()
        .filter(|(n, _)| n == "ScalarVariable")
        .map(|(_, a)| a)
        .collect()
}

#[test]
fn generated_table_matches_the_xml_variable_by_variable() {
    let declared = scalar_variables();
    assert_eq!(declared.len(), VARIABLES.len());
    for (xml, info) in declared.iter().zip(&VARIABLES) {
        assert_eq!(xml["name"], info.name);
        assert_eq!(
            xml["valueReference"].parse::<u32>().unwrap(),
            info.value_reference
        );
        assert_eq!(
            Variable::from_value_reference(info.value_reference),
            Some(info.variable)
        );
        assert_eq!(xml["causality"], format!("{:?}", info.causality).to_lowercase());
    }
    let guid = elements()
        .into_iter()
        .find(|(n, _)| n == "fmiModelDescription")
        .unwrap()
        .1["guid"]
        .clone();
    assert_eq!(guid, GUID);
}

#[test]
fn every_spec_variable_is_declared_with_its_unit() {
    let expected = [
        ("vx", "m/s"),
        ("vy", "m/s"),
        ("steerRate", "rad/s"),
        ("vsx", "m/s"),
        ("Fz", "N"),
        ("Fx", "N"),
        ("Fy", "N"),
        ("Mz", "N.m"),
        ("My", "N.m"),
        ("alphaT", "rad"),
        ("kappaT", "1"),
        ("deflX", "m"),
        ("deflY", "m"),
        ("deflPsi", "rad"),
        ("Calpha", "N/rad"),
        ("Ckappa", "N"),
        ("sigmaY", "m"),
        ("sigmaX", "m"),
        ("Re", "m"),
        ("trail", "m"),
        ("Fz0", "N"),
        ("dampingY", "N.s/m"),
        ("dampingX", "N.s/m"),
        ("sigmaPsi", "m"),
        ("stiffnessPsi", "N.m/rad"),
        ("dampingPsi", "N.m.s/rad"),
        ("contactMass", "kg"),
        ("carcassDampingY", "N.s/m"),
        ("ringMass", "kg"),
        ("ringInertia", "kg.m2"),
        ("ringDampingY", "N.s/m"),
        ("ringDampingX", "N.s/m"),
        ("sigmaTread", "m"),
        ("calphaLoadPeak", "1"),
        ("muX", "1"),
        ("muY", "1"),
        ("muLoadSensitivity", "1"),
        ("boreRadius", "m"),
    ];
    for (name, unit) in expected {
        let info = VARIABLES
            .iter()
            .find(|v| v.name == name)
            .unwrap_or_else(|| panic!("{name} is not declared"));
        assert_eq!(info.unit, unit, "{name}");
        assert_eq!(info.value_type, ValueType::Real, "{name}");
    }
    let model = Variable::TireModel.info();
    assert_eq!(
        (model.value_type, model.start, model.min, model.max),
        (ValueType::Integer, Some(2.0), Some(1.0), Some(4.0)),
        "tireModel is an Integer from 1 to 4 that starts as DDT"
    );
    let friction = Variable::Friction.info();
    assert_eq!(
        (friction.value_type, friction.start, friction.min, friction.max),
        (ValueType::Integer, Some(3.0), Some(1.0), Some(3.0)),
        "friction is an Integer from 1 to 3 that starts as Brush"
    );
}

#[test]
fn every_physics_signal_and_parameter_has_exactly_one_variable() {
    let roles: Vec<Role> = VARIABLES.iter().map(|v| v.variable.role()).collect();
    let mut wanted: Vec<Role> = Input::ALL.map(Role::Input).to_vec();
    wanted.extend(Output::ALL.map(Role::Output));
    wanted.extend(Parameter::ALL.map(Role::Parameter));
    wanted.push(Role::ModelChoice);
    wanted.push(Role::FrictionChoice);
    wanted.push(Role::TireDataFile);
    wanted.extend((0..CONTINUOUS_STATES).map(Role::ContinuousState));
    wanted.extend((0..CONTINUOUS_STATES).map(Role::Derivative));
    wanted.extend((0..GUARDS).map(Role::EventIndicator));
    wanted.push(Role::Time);
    assert_eq!(roles.len(), wanted.len());
    for role in wanted {
        assert_eq!(roles.iter().filter(|r| **r == role).count(), 1, "{role:?}");
        assert_eq!(Variable::with_role(role).role(), role);
    }
    for info in &VARIABLES {
        let causality_fits = match info.variable.role() {
            Role::Input(_) => info.causality == Causality::Input,
            Role::Output(_) => info.causality == Causality::Output,
            Role::Parameter(_) | Role::ModelChoice | Role::FrictionChoice | Role::TireDataFile => {
                info.causality == Causality::Parameter
            }
            Role::ContinuousState(_) | Role::Derivative(_) | Role::EventIndicator(_) => {
                info.causality == Causality::Local
            }
            Role::Time => info.causality == Causality::Independent,
        };
        assert!(causality_fits, "{}", info.name);
    }
}

#[test]
fn start_values_are_the_documented_defaults_and_valid() {
    let start = start_parameters().unwrap();
    assert_eq!(start, Parameters::default());
    start.validate().unwrap();
    for info in &VARIABLES {
        if let (Role::Parameter(p), Some(min)) = (info.variable.role(), info.min) {
            assert!(
                p.check(min - 1e-9).is_err(),
                "{}: values below min must be refused",
                info.name
            );
        }
    }
}

#[test]
fn model_structure_lists_exactly_the_outputs_with_their_feedthrough() {
    let indices: BTreeMap<usize, &str> = VARIABLES
        .iter()
        .enumerate()
        .map(|(i, v)| (i + 1, v.name))
        .collect();
    let mut section = String::new();
    let mut unknowns: BTreeMap<String, Vec<Vec<&str>>> = BTreeMap::new();
    for (name, attributes) in elements() {
        if name == "Outputs" || name == "InitialUnknowns" || name == "Derivatives" {
            section = name;
        } else if name == "Unknown" {
            let index: usize = attributes["index"].parse().unwrap();
            // No dependencies attribute: depends on every known (the derivatives).
            let dependencies: Vec<&str> = attributes
                .get("dependencies")
                .map_or("", |d| d.as_str())
                .split_whitespace()
                .map(|d| indices[&d.parse::<usize>().unwrap()])
                .collect();
            unknowns
                .entry(section.clone())
                .or_default()
                .push(vec![indices[&index]]);
            unknowns
                .get_mut(&section)
                .unwrap()
                .last_mut()
                .unwrap()
                .extend(dependencies);
        }
    }
    // DDT's damped forces sliding together on the friction ellipse (docs/specification.md 4c) make Fx
    // depend on vy and Fy on vsx.
    let expected: Vec<Vec<&str>> = vec![
        vec!["Fx", "vx", "vy", "vsx", "Fz"],
        vec!["Fy", "vx", "vy", "vsx", "Fz"],
        vec!["Mz", "vx", "vy", "steerRate", "vsx", "Fz"],
        vec!["My", "vx", "vy", "vsx", "Fz"],
        // The transient slips divide by the loaded relaxation lengths (docs/specification.md 4b).
        vec!["alphaT", "Fz"],
        vec!["kappaT", "Fz"],
        vec!["deflX"],
        vec!["deflY"],
        vec!["deflPsi"],
    ];
    // Model Exchange: every output also depends on the continuous states.
    let states: Vec<&str> = CONTINUOUS_STATE_VARIABLES.iter().map(|v| v.name()).collect();
    let with_states: Vec<Vec<&str>> = expected
        .iter()
        .map(|row| row.iter().copied().chain(states.iter().copied()).collect())
        .collect();
    assert_eq!(unknowns["Outputs"], with_states);
    // The derivatives, in the order of the state vector, each on every known.
    let derivatives: Vec<Vec<&str>> = DERIVATIVE_VARIABLES.iter().map(|v| vec![v.name()]).collect();
    assert_eq!(unknowns["Derivatives"], derivatives);
    let initial: Vec<Vec<&str>> = expected.into_iter().chain(derivatives).collect();
    assert_eq!(unknowns["InitialUnknowns"], initial);
}

#[test]
fn each_state_derivative_names_its_state() {
    for (state, derivative) in CONTINUOUS_STATE_VARIABLES.iter().zip(DERIVATIVE_VARIABLES) {
        assert_eq!(derivative.name(), format!("der({})", state.name()));
        assert_eq!(state.info().start, Some(0.0), "{}", state.name());
    }
}

/// The FMI 3.0 model description build.rs writes from this one: the same variables with
/// the same value references and attributes in FMI 3.0's types, the same state vector,
/// the event indicators as variables, and the instantiation token the GUID.
#[test]
fn the_fmi3_description_declares_the_same_variables() {
    let fmi3 = elements_of(FMI3_MODEL_DESCRIPTION_XML);
    let root = &fmi3[0];
    assert_eq!(
        (root.0.as_str(), root.1["fmiVersion"].as_str()),
        ("fmiModelDescription", "3.0")
    );
    assert_eq!(root.1["instantiationToken"], GUID);
    let variables: BTreeMap<&str, (&str, &BTreeMap<String, String>)> = fmi3
        .iter()
        .filter(|(_, a)| a.contains_key("valueReference") && a.contains_key("name"))
        .map(|(tag, a)| (a["name"].as_str(), (tag.as_str(), a)))
        .collect();
    assert_eq!(variables.len(), VARIABLES.len());
    let number = |text: Option<&String>| text.map(|t| t.parse::<f64>().unwrap());
    for info in &VARIABLES {
        let (tag, a) = variables[info.name];
        let expected_tag = match info.value_type {
            ValueType::Real => "Float64",
            ValueType::Integer => "Enumeration",
            ValueType::String => "String",
        };
        assert_eq!(tag, expected_tag, "{}", info.name);
        assert_eq!(
            a["valueReference"],
            info.value_reference.to_string(),
            "{}",
            info.name
        );
        let causality = format!("{:?}", info.causality).to_lowercase();
        assert_eq!(a["causality"], causality, "{}", info.name);
        assert_eq!(a["variability"], format!("{:?}", info.variability).to_lowercase());
        if info.value_type != ValueType::String {
            assert_eq!(number(a.get("start")), info.start, "{}", info.name);
        }
        assert_eq!(number(a.get("min")), info.min, "{}", info.name);
        assert_eq!(number(a.get("max")), info.max, "{}", info.name);
        assert_eq!(
            a.get("unit").map_or("", String::as_str),
            info.unit,
            "{}",
            info.name
        );
    }
    let listed = |tag: &str| -> Vec<u32> {
        fmi3.iter()
            .filter(|(t, _)| t == tag)
            .map(|(_, a)| a["valueReference"].parse().unwrap())
            .collect()
    };
    let references =
        |list: &[Variable]| -> Vec<u32> { list.iter().map(|v| v.info().value_reference).collect() };
    assert_eq!(
        listed("ContinuousStateDerivative"),
        references(&DERIVATIVE_VARIABLES)
    );
    assert_eq!(listed("EventIndicator"), references(&EVENT_INDICATOR_VARIABLES));
    assert_eq!(listed("EventIndicator").len(), GUARDS);
    for (k, derivative) in DERIVATIVE_VARIABLES.iter().enumerate() {
        let state = CONTINUOUS_STATE_VARIABLES[k].info().value_reference.to_string();
        assert_eq!(variables[derivative.name()].1["derivative"], state);
    }
    let outputs: Vec<u32> = VARIABLES
        .iter()
        .filter(|v| v.causality == Causality::Output)
        .map(|v| v.value_reference)
        .collect();
    assert_eq!(listed("Output"), outputs);
}
