//! The FMI 3.0 model description, written from the FMI 2.0 one (the one source of the
//! variables) and its vendor annotation (the enumerations' items, the event indicators).
//!
//! The same variables with the same value references, in FMI 3.0's words: Real becomes
//! Float64, an Integer of an enumerated type an Enumeration, `derivative` names a value
//! reference instead of an index, and ModelStructure lists value references, with the
//! event indicators as variables. Units, log categories and the default experiment are
//! the same elements in both versions and are carried over as written.

use std::fmt::Write as _;

use quick_xml::escape::escape;

use crate::{Description, MODEL_DESCRIPTION, Unknown, Variable};

/// FMI 2.0 interface attributes and their FMI 3.0 names; the others have no FMI 3.0
/// counterpart (canInterpolateInputs: FMI 3.0 has no input derivatives) or are written
/// below.
const RENAMED: [(&str, &str); 6] = [
    ("modelIdentifier", "modelIdentifier"),
    (
        "canHandleVariableCommunicationStepSize",
        "canHandleVariableCommunicationStepSize",
    ),
    ("maxOutputDerivativeOrder", "maxOutputDerivativeOrder"),
    ("canGetAndSetFMUstate", "canGetAndSetFMUState"),
    ("canSerializeFMUstate", "canSerializeFMUState"),
    ("providesDirectionalDerivative", "providesDirectionalDerivatives"),
];

fn attributes(pairs: &[(&str, String)]) -> String {
    pairs
        .iter()
        .map(|(key, value)| format!(" {key}=\"{}\"", escape(value.as_str())))
        .collect()
}

/// The text of the element `tag` in the FMI 2.0 source, from `<tag` to its end.
fn element<'a>(xml: &'a str, tag: &str) -> &'a str {
    let start = xml
        .find(&format!("<{tag}"))
        .unwrap_or_else(|| panic!("{MODEL_DESCRIPTION}: no <{tag}>"));
    let rest = &xml[start..];
    let closing = format!("</{tag}>");
    let end = match rest.find(&closing) {
        Some(end) => end + closing.len(),
        None => rest.find("/>").expect("an empty element ends with />") + 2,
    };
    &rest[..end]
}

fn interface(tag: &str, fmi2: &[(String, String)], extra: &[(&str, String)]) -> String {
    let mut pairs: Vec<(&str, String)> = Vec::new();
    for (key, value) in fmi2 {
        if let Some((_, new)) = RENAMED.iter().find(|(old, _)| old == key) {
            pairs.push((new, value.clone()));
        }
        if key == "completedIntegratorStepNotNeeded" {
            pairs.push(("needsCompletedIntegratorStep", (value != "true").to_string()));
        }
    }
    pairs.extend(extra.iter().cloned());
    format!("  <{tag}{}/>\n", attributes(&pairs))
}

/// Value references of the 1-based variable indices in `list`.
fn references(variables: &[Variable], list: &[usize]) -> String {
    list.iter()
        .map(|&i| variables[i - 1].value_reference.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

fn structure_entry(tag: &str, variables: &[Variable], unknown: &Unknown) -> String {
    let mut pairs = vec![(
        "valueReference",
        variables[unknown.index - 1].value_reference.to_string(),
    )];
    if let Some(dependencies) = &unknown.dependencies {
        pairs.push(("dependencies", references(variables, dependencies)));
        if let Some(kind) = &unknown.dependencies_kind {
            pairs.push(("dependenciesKind", kind.clone()));
        }
    }
    format!("    <{tag}{}/>\n", attributes(&pairs))
}

fn variable(description: &Description, variables: &[Variable], v: &Variable) -> String {
    let enumerated = v
        .declared_type
        .as_ref()
        .filter(|t| description.enumerations.iter().any(|e| &e.name == *t));
    let tag = match (v.value_type.as_str(), enumerated) {
        ("Real", _) => "Float64",
        ("Integer", Some(_)) => "Enumeration",
        ("Integer", None) => "Int32",
        ("String", _) => "String",
        (other, _) => panic!("{}: no FMI 3.0 type for {other}", v.name),
    };
    let mut pairs: Vec<(&str, String)> = vec![
        ("name", v.name.clone()),
        ("valueReference", v.value_reference.to_string()),
    ];
    if let Some(text) = &v.description {
        pairs.push(("description", text.clone()));
    }
    pairs.push(("causality", v.causality.clone()));
    pairs.push(("variability", v.variability.clone()));
    if let Some(initial) = &v.initial {
        pairs.push(("initial", initial.clone()));
    }
    let optional = [
        ("declaredType", &v.declared_type),
        ("unit", &v.unit),
        ("displayUnit", &v.display_unit),
        ("min", &v.min),
        ("max", &v.max),
    ];
    pairs.extend(
        optional
            .iter()
            .filter_map(|(k, value)| value.as_ref().map(|x| (*k, x.clone()))),
    );
    if tag == "String" {
        let start = v.start.clone().unwrap_or_default();
        return format!(
            "    <String{}>\n      <Start value=\"{}\"/>\n    </String>\n",
            attributes(&pairs),
            escape(start.as_str())
        );
    }
    if let Some(start) = &v.start {
        pairs.push(("start", start.clone()));
    }
    if let Some(state) = v.derivative {
        pairs.push(("derivative", variables[state - 1].value_reference.to_string()));
    }
    format!("    <{tag}{}/>\n", attributes(&pairs))
}

pub fn generate(xml: &str, description: &Description, variables: &[Variable]) -> String {
    let mut out = String::new();
    let w = &mut out;
    writeln!(w, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>").unwrap();
    writeln!(
        w,
        "<!-- Generated by build.rs from {MODEL_DESCRIPTION} (FMI 2.0), the one source of the variables. Do not edit. -->"
    )
    .unwrap();
    let mut root: Vec<(&str, String)> = vec![("fmiVersion", "3.0".into())];
    for (key, value) in &description.root_attributes {
        match key.as_str() {
            "fmiVersion" | "numberOfEventIndicators" => {}
            "guid" => root.push(("instantiationToken", value.clone())),
            other => root.push((other, value.clone())),
        }
    }
    writeln!(w, "<fmiModelDescription{}>", attributes(&root)).unwrap();
    for (tag, fmi2) in &description.interfaces {
        let extra: Vec<(&str, String)> = match tag.as_str() {
            "CoSimulation" => vec![("hasEventMode", "false".into())],
            _ => Vec::new(),
        };
        w.push_str(&interface(tag, fmi2, &extra));
    }
    writeln!(w, "  {}", element(xml, "UnitDefinitions")).unwrap();
    writeln!(w, "  <TypeDefinitions>").unwrap();
    for enumeration in &description.enumerations {
        let text = description
            .type_descriptions
            .iter()
            .find(|(name, _)| name == &enumeration.name)
            .map(|(_, text)| text.clone())
            .unwrap_or_else(|| panic!("EnumerationType {} has no SimpleType", enumeration.name));
        writeln!(
            w,
            "    <EnumerationType{}>",
            attributes(&[("name", enumeration.name.clone()), ("description", text)])
        )
        .unwrap();
        for (name, value, text) in &enumeration.items {
            let item = [
                ("name", name.clone()),
                ("value", value.to_string()),
                ("description", text.clone()),
            ];
            writeln!(w, "      <Item{}/>", attributes(&item)).unwrap();
        }
        writeln!(w, "    </EnumerationType>").unwrap();
    }
    writeln!(w, "  </TypeDefinitions>").unwrap();
    writeln!(w, "  {}", element(xml, "LogCategories")).unwrap();
    writeln!(w, "  {}", element(xml, "DefaultExperiment")).unwrap();
    writeln!(w, "  <ModelVariables>").unwrap();
    for v in variables {
        w.push_str(&variable(description, variables, v));
    }
    writeln!(w, "  </ModelVariables>").unwrap();
    writeln!(w, "  <ModelStructure>").unwrap();
    for output in &description.outputs {
        w.push_str(&structure_entry("Output", variables, output));
    }
    for &index in &description.derivatives {
        let derivative = Unknown {
            index,
            dependencies: None,
            dependencies_kind: None,
        };
        w.push_str(&structure_entry(
            "ContinuousStateDerivative",
            variables,
            &derivative,
        ));
    }
    for unknown in &description.initial_unknowns {
        w.push_str(&structure_entry("InitialUnknown", variables, unknown));
    }
    for vr in &description.event_indicator_references {
        writeln!(w, "    <EventIndicator valueReference=\"{vr}\"/>").unwrap();
    }
    writeln!(w, "  </ModelStructure>").unwrap();
    writeln!(w, "</fmiModelDescription>").unwrap();
    out
}
