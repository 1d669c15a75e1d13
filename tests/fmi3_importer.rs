//! The packed FMI 3.0 FMU run by a second, independent importer: the FMI 3.0 part of the
//! `fmi` crate (rust-fmi). It unzips `fmi3/TireLag.fmu`, parses its modelDescription.xml
//! with its own schema, loads `binaries/x86_64-linux/TireLag.so` and drives an FMI 3.0
//! Co-Simulation instance. Every model, its `tireModel` enumeration written with
//! fmi3SetInt64, run through it for 200 steps of a fixed input sequence, must give the
//! outputs of the physics core stepped directly. Then a Model Exchange instance of the
//! same FMU, integrated by a solver of this test's own through the crate, must give the
//! same trajectory with the friction limit acting. The FMI 2.0 counterpart is
//! tests/fmi_importer.rs; the sequence, the comparisons and the solver are shared
//! ([`support::fmi_crate`]).

mod support;

use std::fs::File;
use std::io::{Cursor, Read, Write};
use std::path::{Path, PathBuf};

use fmi::fmi3::import::Fmi3Import;
use fmi::fmi3::schema::{Causality, TypeDefinition, VariableType};
use fmi::fmi3::{CoSimulation, Common, Fmi3Model, GetSet, ModelExchange};
use fmi::traits::FmiImport;
use quick_xml::events::{BytesStart, Event};
use support::fmi_crate::{
    self, FRICTION, INDICATORS, INPUTS, MODEL, MU_Y, OUTPUTS, SLIDING_MU, STATES, STEP_SIZE,
    input_references, ok, output_references,
};
use tirelag::physics::{FrictionLaw, ModelKind};

/// The packed FMI 3.0 FMU: `target/fmu/fmi3/TireLag.fmu` (or the path in TIRELAG_FMU3).
fn fmu_path() -> PathBuf {
    support::packed_artifact("TIRELAG_FMU3", "target/fmu/fmi3/TireLag.fmu")
}

const MODEL_DESCRIPTION: &str = "modelDescription.xml";

/// The packed FMU through the crate's FMI 3.0 importer.
///
/// The crate's FMI 3.0 schema (fmi-schema 0.8) has no `unit` or `displayUnit` on Float64
/// variables (the standard's RealVariableAttributes) and refuses any attribute it does
/// not know, so it cannot read a description whose Float64 variables have units. It is
/// handed the packed FMU with those two attributes taken off the Float64 elements,
/// nothing it uses: the binary, the rest of the description and the other files are as
/// packed.
fn import() -> Fmi3Import {
    fmi_crate::install_logger();
    let path = fmu_path();
    fmi::import::new(Cursor::new(without_float_units(&path)))
        .unwrap_or_else(|e| panic!("the fmi crate cannot import {}: {e} ({e:?})", path.display()))
}

/// The FMU at `path`, in memory, with `unit` and `displayUnit` taken off its Float64
/// variables.
fn without_float_units(path: &Path) -> Vec<u8> {
    let file = File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut fmu = zip::ZipArchive::new(file).expect("the FMU is a zip archive");
    let mut xml = String::new();
    fmu.by_name(MODEL_DESCRIPTION)
        .expect("the FMU has a model description")
        .read_to_string(&mut xml)
        .expect("the model description is UTF-8 text");

    let mut reader = quick_xml::Reader::from_str(&xml);
    let mut writer = quick_xml::Writer::new(Vec::new());
    loop {
        let event = match reader.read_event().expect("the model description is XML") {
            Event::Eof => break,
            Event::Empty(e) if e.name().as_ref() == "Float64" => Event::Empty(without_units(&e)),
            Event::Start(e) if e.name().as_ref() == "Float64" => Event::Start(without_units(&e)),
            event => event,
        };
        writer.write_event(event).expect("writing to memory");
    }

    let mut repacked = zip::ZipWriter::new(Cursor::new(Vec::new()));
    for i in 0..fmu.len() {
        let entry = fmu.by_index_raw(i).expect("an entry of the FMU");
        if entry.name() != MODEL_DESCRIPTION {
            repacked.raw_copy_file(entry).expect("copying an entry");
        }
    }
    let stored = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    repacked
        .start_file(MODEL_DESCRIPTION, stored)
        .expect("a new model description entry");
    repacked
        .write_all(&writer.into_inner())
        .expect("writing the model description");
    repacked.finish().expect("the repacked FMU").into_inner()
}

fn without_units(element: &BytesStart) -> BytesStart<'static> {
    let kept = element
        .attributes()
        .map(|a| a.expect("a well-formed attribute"))
        .filter(|a| !matches!(a.key.as_ref(), "unit" | "displayUnit"));
    BytesStart::new(element.name().as_ref().to_owned()).with_attributes(kept)
}

/// The (name, value) items of the enumeration type `name` in the crate's reading.
fn enumeration_items(import: &Fmi3Import, name: &str) -> Vec<(String, i64)> {
    let types = import
        .model_description()
        .type_definitions
        .as_ref()
        .expect("the fmi crate finds the TypeDefinitions");
    types
        .type_definitions
        .iter()
        .find_map(|t| match t {
            TypeDefinition::Enumeration(e) if e.name == name => Some(
                e.items
                    .iter()
                    .map(|item| (item.name.clone(), item.value))
                    .collect(),
            ),
            _ => None,
        })
        .unwrap_or_else(|| panic!("the fmi crate finds no EnumerationType {name}"))
}

#[test]
fn fmi_crate_reads_the_model_description() {
    let import = import();
    let md = import.model_description();
    assert_eq!(md.fmi_version, "3.0");
    assert_eq!(md.model_name, "TireLag");
    assert_eq!(md.instantiation_token, support::GUID);
    let cs = md
        .co_simulation
        .as_ref()
        .expect("the fmi crate finds the CoSimulation element");
    assert_eq!(cs.model_identifier, "TireLag");
    assert!(!cs.has_event_mode.unwrap_or(false));
    assert_eq!(cs.can_handle_variable_communication_step_size, Some(true));
    let me = md
        .model_exchange
        .as_ref()
        .expect("the fmi crate finds the ModelExchange element");
    assert_eq!(me.model_identifier, "TireLag");
    assert!(!me.needs_completed_integrator_step.unwrap_or(false));
    assert!(md.scheduled_execution.is_none());

    let variable = |name: &str| {
        md.model_variables
            .find_by_name(name)
            .unwrap_or_else(|| panic!("the fmi crate does not find {name}"))
    };
    let signals = INPUTS
        .map(|(name, vr, _)| (name, vr, Causality::Input))
        .into_iter()
        .chain(OUTPUTS.map(|(name, vr, _)| (name, vr, Causality::Output)))
        .chain([("time", 0, Causality::Independent)]);
    for (name, vr, causality) in signals {
        let v = variable(name);
        assert_eq!(v.value_reference(), vr, "{name}");
        assert_eq!(v.causality(), causality, "{name}");
        assert_eq!(v.data_type(), VariableType::FmiFloat64, "{name}");
    }

    // The state vector and the event indicators, in the order of the crate's Model
    // Exchange calls.
    let derivatives: Vec<u32> = md
        .model_structure
        .continuous_state_derivatives()
        .map(|u| u.value_reference)
        .collect();
    let expected: Vec<u32> = (300..=305).chain(310..=321).collect();
    assert_eq!(derivatives, expected);
    assert_eq!(derivatives.len(), STATES);
    let indicators: Vec<u32> = md
        .model_structure
        .event_indicators()
        .map(|u| u.value_reference)
        .collect();
    assert_eq!(indicators, (400..=408).collect::<Vec<u32>>());
    assert_eq!(indicators.len(), INDICATORS);
    for vr in indicators {
        let v = md
            .model_variables
            .iter_abstract()
            .find(|v| v.value_reference() == vr)
            .unwrap_or_else(|| panic!("no variable has the event indicator's reference {vr}"));
        assert_eq!(v.causality(), Causality::Local, "{}", v.name());
        assert_eq!(v.data_type(), VariableType::FmiFloat64, "{}", v.name());
    }

    // The two selectors' types. (The crate's 0.8 schema reads no <Enumeration> variables:
    // the selectors themselves are reached through fmi3GetInt64/fmi3SetInt64 below.)
    let models = ModelKind::ALL.map(|m| (m.name().to_owned(), m as i64));
    assert_eq!(enumeration_items(&import, "TireLagModel"), models);
    let laws = FrictionLaw::ALL.map(|f| (f.name().to_owned(), f as i64));
    assert_eq!(enumeration_items(&import, "TireFriction"), laws);
}

#[test]
fn fmi_crate_co_simulation_matches_the_physics_core_for_every_model() {
    let import = import();
    // hasEventMode="false": an importer that would use Event Mode is refused (the FMU logs
    // why).
    assert!(matches!(
        import.instantiate_cs("fmi3_importer_event_mode", false, true, true, false, &[]),
        Err(fmi::Error::Instantiation)
    ));

    let (input_vrs, output_vrs) = (input_references(), output_references());
    for kind in ModelKind::ALL {
        let name = format!("fmi3_importer_{}", kind.name());
        let mut fmu = import
            .instantiate_cs(&name, false, true, false, false, &[])
            .unwrap_or_else(|e| panic!("the fmi crate cannot instantiate the FMU: {e} ({e:?})"));
        assert_eq!(fmu.get_version(), "3.0");
        ok(
            "fmi3SetInt64(tireModel)",
            fmu.set_int64(&[MODEL.1], &[kind as i64]),
        );
        ok(
            "fmi3EnterInitializationMode",
            fmu.enter_initialization_mode(None, 0.0, None),
        );
        ok("fmi3ExitInitializationMode", fmu.exit_initialization_mode());
        let mut model = [0];
        ok("fmi3GetInt64(tireModel)", fmu.get_int64(&[MODEL.1], &mut model));
        assert_eq!(model[0], kind as i64, "the FMU reports the model it was given");

        let mut y = [0.0; 9];
        ok("fmi3GetFloat64(outputs)", fmu.get_float64(&output_vrs, &mut y));
        fmi_crate::co_simulation_matches_the_core(kind, y, |k, u| {
            ok("fmi3SetFloat64(inputs)", fmu.set_float64(&input_vrs, &u));
            let t = k as f64 * STEP_SIZE;
            // Set to what the FMU must overwrite.
            let (mut event_handling_needed, mut terminate, mut early_return) = (true, true, true);
            let mut last_successful_time = f64::NAN;
            ok(
                "fmi3DoStep",
                fmu.do_step(
                    t,
                    STEP_SIZE,
                    true,
                    &mut event_handling_needed,
                    &mut terminate,
                    &mut early_return,
                    &mut last_successful_time,
                ),
            );
            assert!(
                !(event_handling_needed || terminate || early_return),
                "fmi3DoStep at {t} s: eventHandlingNeeded {event_handling_needed}, \
                 terminateSimulation {terminate}, earlyReturn {early_return}"
            );
            assert!(
                (last_successful_time - (t + STEP_SIZE)).abs() <= 1e-12,
                "fmi3DoStep at {t} s by {STEP_SIZE} s: lastSuccessfulTime {last_successful_time}"
            );
            let mut y = [0.0; 9];
            ok("fmi3GetFloat64(outputs)", fmu.get_float64(&output_vrs, &mut y));
            y
        });
        ok("fmi3Terminate", fmu.terminate());
    }
}

/// Every model with the Coulomb law at a low lateral limit: the FMI 3.0 Model Exchange
/// interface through the `fmi` crate, integrated by [`fmi_crate::Integrator`] (the FMI 2.0
/// test's solver), against the exact step of the physics core at every communication
/// point.
#[test]
fn fmi_crate_model_exchange_matches_the_exact_step_for_every_model() {
    let import = import();
    let (input_vrs, output_vrs) = (input_references(), output_references());
    for kind in ModelKind::ALL {
        let name = format!("fmi3_importer_me_{}", kind.name());
        let mut fmu = import
            .instantiate_me(&name, false, true)
            .unwrap_or_else(|e| panic!("the fmi crate cannot instantiate the FMU: {e} ({e:?})"));
        ok(
            "fmi3SetInt64(tireModel, friction)",
            fmu.set_int64(
                &[MODEL.1, FRICTION.1],
                &[kind as i64, FrictionLaw::Coulomb as i64],
            ),
        );
        ok("fmi3SetFloat64(muY)", fmu.set_float64(&[MU_Y.1], &[SLIDING_MU]));
        ok(
            "fmi3EnterInitializationMode",
            fmu.enter_initialization_mode(None, 0.0, None),
        );
        ok("fmi3ExitInitializationMode", fmu.exit_initialization_mode());
        assert_eq!(fmu.get_number_of_continuous_states(), Ok(STATES));
        assert_eq!(fmu.get_number_of_event_indicators(), Ok(INDICATORS));
        fmi_crate::model_exchange_matches_the_exact_step(
            kind,
            fmu,
            |fmu, u| ok("fmi3SetFloat64(inputs)", fmu.set_float64(&input_vrs, u)),
            |fmu| {
                let mut y = [0.0; 9];
                ok("fmi3GetFloat64(outputs)", fmu.get_float64(&output_vrs, &mut y));
                y
            },
        );
    }
}
