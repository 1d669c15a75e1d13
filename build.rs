//! Reads `modelDescription/modelDescription.xml`, the one source of truth for the FMU's
//! variables, and generates from it the Rust variable table (`variables.rs` in OUT_DIR)
//! and the FMI 3.0 model description (`fmi3/modelDescription.xml` in OUT_DIR, packed into
//! `target/fmu/fmi3/TireLag.fmu`; [`fmi3_description`]). The FMI layer includes the
//! table, so neither XML and the code can disagree.

#[path = "build/fmi3_description.rs"]
mod fmi3_description;

use std::fmt::Write as _;
use std::path::Path;

use quick_xml::Reader;
use quick_xml::events::{BytesStart, Event};

const MODEL_DESCRIPTION: &str = "modelDescription/modelDescription.xml";

struct Variable {
    name: String,
    description: Option<String>,
    initial: Option<String>,
    declared_type: Option<String>,
    display_unit: Option<String>,
    value_reference: u32,
    causality: String,
    variability: String,
    value_type: String,
    start: Option<String>,
    min: Option<String>,
    max: Option<String>,
    unit: Option<String>,
    /// The index (1-based) of the state this variable is the derivative of.
    derivative: Option<usize>,
}

/// An Unknown of ModelStructure: a variable's index (1-based) and what it depends on.
struct Unknown {
    index: usize,
    /// Indices (1-based) of the knowns; `None`: every known.
    dependencies: Option<Vec<usize>>,
    dependencies_kind: Option<String>,
}

/// An FMI 3.0 EnumerationType from the vendor annotation.
struct EnumerationType {
    name: String,
    /// (name, value, description)
    items: Vec<(String, i64, String)>,
}

/// What the model description says beyond its variables.
struct Description {
    guid: String,
    model_identifier: String,
    event_indicators: usize,
    /// ModelStructure/Derivatives: the index (1-based) of each state derivative, in the
    /// order of the continuous state vector.
    derivatives: Vec<usize>,
    outputs: Vec<Unknown>,
    initial_unknowns: Vec<Unknown>,
    /// The root's attributes, and those of `<ModelExchange>` and `<CoSimulation>`.
    root_attributes: Vec<(String, String)>,
    interfaces: Vec<(String, Vec<(String, String)>)>,
    /// SimpleType name -> description.
    type_descriptions: Vec<(String, String)>,
    /// The vendor annotation's FMI 3.0 additions: the enumerations' items and the value
    /// references of the event-indicator variables, in the order of the indicators.
    enumerations: Vec<EnumerationType>,
    event_indicator_references: Vec<u32>,
}

fn attribute(element: &BytesStart, key: &str) -> Option<String> {
    element
        .try_get_attribute(key)
        .unwrap_or_else(|e| panic!("{MODEL_DESCRIPTION}: bad attribute {key}: {e}"))
        .map(|a| {
            a.normalized_value(quick_xml::XmlVersion::Implicit1_0)
                .unwrap_or_else(|e| panic!("{MODEL_DESCRIPTION}: bad value of {key}: {e}"))
                .into_owned()
        })
}

fn required(element: &BytesStart, key: &str) -> String {
    attribute(element, key).unwrap_or_else(|| {
        let tag = element.name().as_ref().to_owned();
        panic!("{MODEL_DESCRIPTION}: <{tag}> has no {key}")
    })
}

/// `steerRate` -> `SteerRate`, `der(tireState1)` -> `DerTireState1`: the Rust enum
/// variant of a variable (each run of letters and digits, capitalised).
fn variant_name(name: &str) -> String {
    let variant: String = name
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|part| !part.is_empty())
        .flat_map(|part| {
            let mut chars = part.chars();
            let first = chars.next().expect("not empty");
            first.to_uppercase().chain(chars)
        })
        .collect();
    assert!(!variant.is_empty(), "variable name '{name}' has no letters");
    variant
}

fn float_literal(text: &Option<String>) -> String {
    match text {
        Some(t) => {
            let v: f64 = t
                .parse()
                .unwrap_or_else(|_| panic!("{MODEL_DESCRIPTION}: '{t}' is not a number"));
            format!("Some({v:?}_f64)")
        }
        None => "None".to_owned(),
    }
}

fn all_attributes(element: &BytesStart) -> Vec<(String, String)> {
    element
        .attributes()
        .map(|a| {
            let a = a.unwrap_or_else(|e| panic!("{MODEL_DESCRIPTION}: bad attribute: {e}"));
            let key = a.key.as_ref().to_owned();
            let value = a
                .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                .unwrap_or_else(|e| panic!("{MODEL_DESCRIPTION}: bad value of {key}: {e}"))
                .into_owned();
            (key, value)
        })
        .collect()
}

fn indices(text: &str, what: &str) -> Vec<usize> {
    text.split_whitespace()
        .map(|i| {
            i.parse()
                .unwrap_or_else(|_| panic!("{what}: '{i}' is not an index"))
        })
        .collect()
}

fn unknown(element: &BytesStart) -> Unknown {
    Unknown {
        index: indices(&required(element, "index"), "Unknown index")[0],
        dependencies: attribute(element, "dependencies").map(|d| indices(&d, "dependencies")),
        dependencies_kind: attribute(element, "dependenciesKind"),
    }
}

fn parse(xml: &str) -> (Description, Vec<Variable>) {
    let mut reader = Reader::from_str(xml);
    reader.config_mut().trim_text(true);
    let (mut guid, mut model_identifier, mut event_indicators) = (None, None, 0);
    let mut root_attributes = Vec::new();
    let mut interfaces = Vec::new();
    let mut type_descriptions = Vec::new();
    let mut enumerations: Vec<EnumerationType> = Vec::new();
    let mut event_indicator_references = Vec::new();
    let (mut derivatives, mut outputs, mut initial_unknowns) = (Vec::new(), Vec::new(), Vec::new());
    // The ModelStructure list being read: Outputs, Derivatives or InitialUnknowns.
    let mut list: Option<String> = None;
    let mut variables: Vec<Variable> = Vec::new();
    let mut open: Option<Variable> = None;
    loop {
        match reader.read_event() {
            Ok(Event::Start(e)) | Ok(Event::Empty(e)) => match e.name().as_ref() {
                "fmiModelDescription" => {
                    guid = Some(required(&e, "guid"));
                    event_indicators = attribute(&e, "numberOfEventIndicators").map_or(0, |n| {
                        n.parse().expect("numberOfEventIndicators must be an integer")
                    });
                    root_attributes = all_attributes(&e);
                }
                tag @ ("CoSimulation" | "ModelExchange") => {
                    let identifier = required(&e, "modelIdentifier");
                    if let Some(other) = &model_identifier {
                        assert_eq!(other, &identifier, "<{tag}> has another modelIdentifier");
                    }
                    model_identifier = Some(identifier);
                    interfaces.push((tag.to_owned(), all_attributes(&e)));
                }
                "SimpleType" => type_descriptions.push((
                    required(&e, "name"),
                    attribute(&e, "description").unwrap_or_default(),
                )),
                "EnumerationType" => enumerations.push(EnumerationType {
                    name: required(&e, "name"),
                    items: Vec::new(),
                }),
                "Item" => enumerations
                    .last_mut()
                    .expect("<Item> outside <EnumerationType>")
                    .items
                    .push((
                        required(&e, "name"),
                        required(&e, "value")
                            .parse()
                            .expect("an Item's value must be an integer"),
                        attribute(&e, "description").unwrap_or_default(),
                    )),
                "EventIndicators" => {
                    event_indicator_references = required(&e, "valueReferences")
                        .split_whitespace()
                        .map(|vr| {
                            vr.parse()
                                .expect("EventIndicators: value references are integers")
                        })
                        .collect()
                }
                tag @ ("Outputs" | "Derivatives" | "InitialUnknowns") => list = Some(tag.to_owned()),
                "Unknown" => match list.as_deref() {
                    Some("Derivatives") => derivatives.push(unknown(&e).index),
                    Some("Outputs") => outputs.push(unknown(&e)),
                    Some("InitialUnknowns") => initial_unknowns.push(unknown(&e)),
                    _ => panic!("{MODEL_DESCRIPTION}: <Unknown> outside a ModelStructure list"),
                },
                "ScalarVariable" => {
                    open = Some(Variable {
                        name: required(&e, "name"),
                        description: attribute(&e, "description"),
                        initial: attribute(&e, "initial"),
                        declared_type: None,
                        display_unit: None,
                        value_reference: required(&e, "valueReference")
                            .parse()
                            .expect("valueReference must be an unsigned integer"),
                        causality: attribute(&e, "causality").unwrap_or("local".into()),
                        variability: attribute(&e, "variability").unwrap_or("continuous".into()),
                        value_type: String::new(),
                        start: None,
                        min: None,
                        max: None,
                        unit: None,
                        derivative: None,
                    })
                }
                tag @ ("Real" | "Integer" | "Enumeration" | "Boolean" | "String") => {
                    if let Some(v) = open.as_mut() {
                        v.value_type = tag.to_owned();
                        v.start = attribute(&e, "start");
                        v.min = attribute(&e, "min");
                        v.max = attribute(&e, "max");
                        v.unit = attribute(&e, "unit");
                        v.declared_type = attribute(&e, "declaredType");
                        v.display_unit = attribute(&e, "displayUnit");
                        v.derivative = attribute(&e, "derivative")
                            .map(|i| i.parse().expect("derivative must be a variable index"));
                    }
                }
                _ => {}
            },
            Ok(Event::End(e))
                if matches!(e.name().as_ref(), "Outputs" | "Derivatives" | "InitialUnknowns") =>
            {
                list = None
            }
            Ok(Event::End(e)) if e.name().as_ref() == "ScalarVariable" => {
                variables.push(open.take().expect("unbalanced <ScalarVariable>"));
            }
            Ok(Event::Eof) => break,
            Ok(_) => {}
            Err(e) => panic!(
                "{MODEL_DESCRIPTION}: XML error at {}: {e}",
                reader.error_position()
            ),
        }
    }
    (
        Description {
            guid: guid.expect("no guid in the model description"),
            model_identifier: model_identifier.expect("no <CoSimulation modelIdentifier>"),
            event_indicators,
            derivatives,
            outputs,
            initial_unknowns,
            root_attributes,
            interfaces,
            type_descriptions,
            enumerations,
            event_indicator_references,
        },
        variables,
    )
}

fn check(variables: &[Variable]) {
    for (i, v) in variables.iter().enumerate() {
        assert!(
            matches!(v.value_type.as_str(), "Real" | "Integer" | "String"),
            "{}: only Real, Integer and String variables are supported (libcosim ignores Enumeration), found {}",
            v.name,
            v.value_type
        );
        for w in &variables[..i] {
            assert!(w.name != v.name, "variable {} is declared twice", v.name);
            assert!(
                w.value_reference != v.value_reference,
                "{} and {} share value reference {}",
                w.name,
                v.name,
                v.value_reference
            );
        }
    }
}

fn generate(guid: &str, model_identifier: &str, variables: &[Variable]) -> String {
    let mut out = String::new();
    let w = &mut out;
    writeln!(
        w,
        "// Generated by build.rs from {MODEL_DESCRIPTION}. Do not edit."
    )
    .unwrap();
    writeln!(
        w,
        "/// GUID of the model description; fmi2Instantiate must be given this one."
    )
    .unwrap();
    writeln!(w, "pub const GUID: &str = {guid:?};").unwrap();
    writeln!(
        w,
        "/// Model identifier: the binary's name and the exported functions' prefix."
    )
    .unwrap();
    writeln!(w, "pub const MODEL_IDENTIFIER: &str = {model_identifier:?};").unwrap();
    writeln!(
        w,
        "/// The model description, verbatim, for checks at run time and in tests."
    )
    .unwrap();
    writeln!(
        w,
        "pub const MODEL_DESCRIPTION_XML: &str = include_str!(concat!(env!(\"CARGO_MANIFEST_DIR\"), \"/{MODEL_DESCRIPTION}\"));"
    )
    .unwrap();
    writeln!(
        w,
        "/// The FMI 3.0 model description build.rs wrote from it (the FMI 3.0 FMU's).\npub const FMI3_MODEL_DESCRIPTION_XML: &str = include_str!(concat!(env!(\"OUT_DIR\"), \"/fmi3/modelDescription.xml\"));"
    )
    .unwrap();
    writeln!(
        w,
        "\n/// Every ScalarVariable of the model description, in declaration order."
    )
    .unwrap();
    writeln!(
        w,
        "#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]\npub enum Variable {{"
    )
    .unwrap();
    for v in variables {
        writeln!(w, "    /// `{}`, value reference {}", v.name, v.value_reference).unwrap();
        writeln!(w, "    {},", variant_name(&v.name)).unwrap();
    }
    writeln!(w, "}}\n").unwrap();
    writeln!(
        w,
        "/// Attributes of each variable, indexed by `Variable as usize`."
    )
    .unwrap();
    writeln!(w, "pub const VARIABLES: [VariableInfo; {}] = [", variables.len()).unwrap();
    for v in variables {
        let causality = variant_name(&v.causality);
        let variability = variant_name(&v.variability);
        writeln!(
            w,
            "    VariableInfo {{ variable: Variable::{}, name: {:?}, value_reference: {}, causality: Causality::{causality}, variability: Variability::{variability}, value_type: ValueType::{}, start: {}, min: {}, max: {}, unit: {:?} }},",
            variant_name(&v.name),
            v.name,
            v.value_reference,
            v.value_type,
            float_literal(&v.start.clone().filter(|_| v.value_type != "String")),
            float_literal(&v.min),
            float_literal(&v.max),
            v.unit.as_deref().unwrap_or(""),
        )
        .unwrap();
    }
    writeln!(w, "];\n").unwrap();
    let largest = variables.iter().map(|v| v.value_reference).max().unwrap_or(0);
    writeln!(
        w,
        "/// The variable of each value reference: one load, no search. `None` where no\n/// variable has that value reference."
    )
    .unwrap();
    writeln!(
        w,
        "pub const VARIABLE_BY_VALUE_REFERENCE: [Option<Variable>; {}] = [",
        largest + 1
    )
    .unwrap();
    for vr in 0..=largest {
        match variables.iter().find(|v| v.value_reference == vr) {
            Some(v) => writeln!(w, "    Some(Variable::{}),", variant_name(&v.name)).unwrap(),
            None => writeln!(w, "    None,").unwrap(),
        }
    }
    writeln!(w, "];\n").unwrap();
    writeln!(w, "impl Variable {{").unwrap();
    writeln!(
        w,
        "    /// The variable with this value reference, if there is one."
    )
    .unwrap();
    writeln!(
        w,
        "    pub const fn from_value_reference(value_reference: u32) -> Option<Variable> {{"
    )
    .unwrap();
    writeln!(
        w,
        "        if (value_reference as usize) < VARIABLE_BY_VALUE_REFERENCE.len() {{\n            VARIABLE_BY_VALUE_REFERENCE[value_reference as usize]\n        }} else {{\n            None\n        }}\n    }}\n}}"
    )
    .unwrap();
    out
}

/// The continuous states, in the order of ModelStructure/Derivatives: (state, derivative)
/// as positions in `variables`. Checks that each listed unknown is a derivative and that
/// every derivative is listed.
fn continuous_states(description: &Description, variables: &[Variable]) -> Vec<(usize, usize)> {
    let states: Vec<(usize, usize)> = description
        .derivatives
        .iter()
        .map(|&index| {
            let derivative = index - 1;
            let v = variables
                .get(derivative)
                .unwrap_or_else(|| panic!("ModelStructure/Derivatives: no variable {index}"));
            let state = v.derivative.unwrap_or_else(|| {
                panic!(
                    "ModelStructure/Derivatives lists {}, which has no derivative=",
                    v.name
                )
            });
            assert!(
                state >= 1 && state <= variables.len(),
                "{}: derivative={state} is not a variable",
                v.name
            );
            (state - 1, derivative)
        })
        .collect();
    let declared = variables.iter().filter(|v| v.derivative.is_some()).count();
    assert_eq!(
        declared,
        states.len(),
        "every variable with derivative= must be listed in ModelStructure/Derivatives"
    );
    states
}

fn generate_continuous_states(
    out: &mut String,
    description: &Description,
    variables: &[Variable],
    states: &[(usize, usize)],
) {
    let w = out;
    let list = |pick: fn(&(usize, usize)) -> usize| {
        states
            .iter()
            .map(|s| format!("Variable::{}", variant_name(&variables[pick(s)].name)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let indicators: Vec<String> = description
        .event_indicator_references
        .iter()
        .map(|&vr| {
            let v = variables
                .iter()
                .find(|v| v.value_reference == vr)
                .unwrap_or_else(|| panic!("EventIndicators: no variable has value reference {vr}"));
            assert!(
                v.causality == "local" && v.value_type == "Real",
                "EventIndicators: {} must be a local Real",
                v.name
            );
            format!("Variable::{}", variant_name(&v.name))
        })
        .collect();
    assert_eq!(
        indicators.len(),
        description.event_indicators,
        "the vendor annotation's EventIndicators must list numberOfEventIndicators variables"
    );
    writeln!(
        w,
        "/// The event-indicator variables, in the order of the indicators.\npub const EVENT_INDICATOR_VARIABLES: [Variable; {}] = [{}];",
        indicators.len(),
        indicators.join(", ")
    )
    .unwrap();
    writeln!(
        w,
        "/// The continuous states (Model Exchange), in the order of the state vector.\npub const CONTINUOUS_STATE_VARIABLES: [Variable; {}] = [{}];",
        states.len(),
        list(|s| s.0)
    )
    .unwrap();
    writeln!(
        w,
        "/// The derivative of each continuous state, in the same order.\npub const DERIVATIVE_VARIABLES: [Variable; {}] = [{}];",
        states.len(),
        list(|s| s.1)
    )
    .unwrap();
}

fn main() {
    println!("cargo:rerun-if-changed={MODEL_DESCRIPTION}");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=build/fmi3_description.rs");
    let xml = std::fs::read_to_string(MODEL_DESCRIPTION)
        .unwrap_or_else(|e| panic!("cannot read {MODEL_DESCRIPTION}: {e}"));
    let (description, variables) = parse(&xml);
    check(&variables);
    let states = continuous_states(&description, &variables);
    let mut code = generate(&description.guid, &description.model_identifier, &variables);
    generate_continuous_states(&mut code, &description, &variables, &states);
    let out_dir = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
    std::fs::write(Path::new(&out_dir).join("variables.rs"), code).expect("cannot write variables.rs");
    let fmi3 = fmi3_description::generate(&xml, &description, &variables);
    let fmi3_dir = Path::new(&out_dir).join("fmi3");
    std::fs::create_dir_all(&fmi3_dir).expect("cannot make OUT_DIR/fmi3");
    std::fs::write(fmi3_dir.join("modelDescription.xml"), fmi3)
        .expect("cannot write the FMI 3.0 model description");
}
