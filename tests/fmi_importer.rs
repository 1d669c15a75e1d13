//! The packed FMU run by a second, independent importer: the `fmi` crate (rust-fmi). It
//! unzips `TireLag.fmu`, parses its modelDescription.xml with its own schema, loads
//! `binaries/linux64/TireLag.so` and drives an FMI 2.0 Co-Simulation instance. Every model,
//! run through it for 200 steps of a fixed input sequence, must give the outputs of the
//! physics core stepped directly. Then a Model Exchange instance of the same FMU,
//! integrated by a solver of this test's own through the crate, must give the same
//! trajectory with the friction limit acting. (tests/fmi3_importer.rs does the same
//! through the crate's FMI 3.0 importer; what the two share is in
//! [`support::fmi_crate`].)

mod support;

use std::path::PathBuf;

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common};
use fmi::fmi2::schema::{Causality, ScalarVariableElement};
use fmi::traits::FmiImport;
use support::fmi_crate::{
    self, FRICTION, INPUTS, MODEL, MU_Y, OUTPUTS, SLIDING_MU, STEP_SIZE, input_references, ok,
    output_references,
};
use tirelag::physics::{FrictionLaw, ModelKind};

/// The packed FMU: `target/fmu/TireLag.fmu` (or the path in TIRELAG_FMU).
fn fmu_path() -> PathBuf {
    support::packed_artifact("TIRELAG_FMU", "target/fmu/TireLag.fmu")
}

fn import() -> Fmi2Import {
    fmi_crate::install_logger();
    let path = fmu_path();
    fmi::import::from_path(&path)
        .unwrap_or_else(|e| panic!("the fmi crate cannot import {}: {e} ({e:?})", path.display()))
}

#[test]
fn fmi_crate_reads_the_model_description() {
    let import = import();
    let md = import.model_description();
    assert_eq!(md.fmi_version, "2.0");
    assert_eq!(md.model_name, "TireLag");
    assert_eq!(md.guid, support::GUID);
    let cs = md
        .co_simulation
        .as_ref()
        .expect("the fmi crate finds the CoSimulation element");
    assert_eq!(cs.model_identifier, "TireLag");
    let me = md
        .model_exchange
        .as_ref()
        .expect("the fmi crate finds the ModelExchange element");
    assert_eq!(me.model_identifier, "TireLag");

    let variable = |name: &str| {
        md.model_variable_by_name(name)
            .unwrap_or_else(|e| panic!("the fmi crate does not find {name}: {e}"))
    };
    for (name, vr, _) in INPUTS {
        let v = variable(name);
        assert_eq!(v.value_reference, vr, "{name}");
        assert_eq!(v.causality, Causality::Input, "{name}");
        assert!(matches!(v.elem, ScalarVariableElement::Real(_)), "{name}");
    }
    for (name, vr, _) in OUTPUTS {
        let v = variable(name);
        assert_eq!(v.value_reference, vr, "{name}");
        assert_eq!(v.causality, Causality::Output, "{name}");
        assert!(matches!(v.elem, ScalarVariableElement::Real(_)), "{name}");
    }
    let model = variable(MODEL.0);
    assert_eq!(model.value_reference, MODEL.1);
    assert_eq!(model.causality, Causality::Parameter);
    assert!(matches!(model.elem, ScalarVariableElement::Integer(_)));
}

#[test]
fn fmi_crate_co_simulation_matches_the_physics_core_for_every_model() {
    let import = import();
    let (input_vrs, output_vrs) = (input_references(), output_references());
    for kind in ModelKind::ALL {
        let mut fmu = import
            .instantiate_cs(&format!("fmi_importer_{}", kind.name()), false, true)
            .unwrap_or_else(|e| panic!("the fmi crate cannot instantiate the FMU: {e} ({e:?})"));
        assert_eq!(Common::get_version(&fmu), "2.0");
        assert_eq!(fmu.get_types_platform(), "default");
        ok("fmi2SetupExperiment", fmu.setup_experiment(None, 0.0, None));
        ok(
            "fmi2SetInteger(tireModel)",
            fmu.set_integer(&[MODEL.1], &[kind as i32]),
        );
        ok(
            "fmi2EnterInitializationMode",
            Common::enter_initialization_mode(&mut fmu),
        );
        ok(
            "fmi2ExitInitializationMode",
            Common::exit_initialization_mode(&mut fmu),
        );
        let mut model = [0];
        ok("fmi2GetInteger(model)", fmu.get_integer(&[MODEL.1], &mut model));
        assert_eq!(model[0], kind as i32, "the FMU reports the model it was given");

        let mut y = [0.0; 9];
        ok("fmi2GetReal(outputs)", fmu.get_real(&output_vrs, &mut y));
        fmi_crate::co_simulation_matches_the_core(kind, y, |k, u| {
            ok("fmi2SetReal(inputs)", fmu.set_real(&input_vrs, &u));
            ok("fmi2DoStep", fmu.do_step(k as f64 * STEP_SIZE, STEP_SIZE, true));
            let mut y = [0.0; 9];
            ok("fmi2GetReal(outputs)", fmu.get_real(&output_vrs, &mut y));
            y
        });
        ok("fmi2Terminate", Common::terminate(&mut fmu));
    }
}

/// Every model with the Coulomb law at a low lateral limit: the Model Exchange interface
/// through the `fmi` crate, integrated by [`fmi_crate::Integrator`], against the exact
/// step of the physics core at every communication point.
#[test]
fn fmi_crate_model_exchange_matches_the_exact_step_for_every_model() {
    let import = import();
    let (input_vrs, output_vrs) = (input_references(), output_references());
    for kind in ModelKind::ALL {
        let mut fmu = import
            .instantiate_me(&format!("fmi_importer_me_{}", kind.name()), false, true)
            .unwrap_or_else(|e| panic!("the fmi crate cannot instantiate the FMU: {e} ({e:?})"));
        ok("fmi2SetupExperiment", fmu.setup_experiment(None, 0.0, None));
        ok(
            "fmi2SetInteger",
            fmu.set_integer(
                &[MODEL.1, FRICTION.1],
                &[kind as i32, FrictionLaw::Coulomb as i32],
            ),
        );
        ok("fmi2SetReal(muY)", fmu.set_real(&[MU_Y.1], &[SLIDING_MU]));
        ok(
            "fmi2EnterInitializationMode",
            Common::enter_initialization_mode(&mut fmu),
        );
        ok(
            "fmi2ExitInitializationMode",
            Common::exit_initialization_mode(&mut fmu),
        );
        fmi_crate::model_exchange_matches_the_exact_step(
            kind,
            fmu,
            |fmu, u| ok("fmi2SetReal(inputs)", fmu.set_real(&input_vrs, u)),
            |fmu| {
                let mut y = [0.0; 9];
                ok("fmi2GetReal(outputs)", fmu.get_real(&output_vrs, &mut y));
                y
            },
        );
    }
}
