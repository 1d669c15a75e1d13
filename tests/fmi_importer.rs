//! The packed FMU run by a second, independent importer: the `fmi` crate (rust-fmi). It
//! unzips `TireLag.fmu`, parses its modelDescription.xml with its own schema, loads
//! `binaries/linux64/TireLag.so` and drives an FMI 2.0 Co-Simulation instance. Every model,
//! run through it for 200 steps of a fixed input sequence, must give the outputs of the
//! physics core stepped directly. Then a Model Exchange instance of the same FMU,
//! integrated by a solver of this test's own through the crate, must give the same
//! trajectory with the friction limit acting.

mod support;

use std::path::PathBuf;
use std::sync::Once;

use fmi::EventFlags;
use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, ModelExchange};
use fmi::fmi2::schema::{Causality, ScalarVariableElement};
use fmi::fmi2::{Fmi2Error, Fmi2Res};
use fmi::traits::FmiImport;
use tirelag::physics::{FrictionLaw, Input, ModelKind, Output, Parameter, Parameters, Tire};

const STEP_SIZE: f64 = 0.01;
const STEPS: usize = 200;
/// The packed binary and this test's build of the core are two compilations of the same
/// code: with the default Brush law the adaptive sliding integration can round
/// differently between them, far below its 1e-12 accuracy per substep.
const RELATIVE_TOLERANCE: f64 = 1e-10;

const MODEL: (&str, u32) = ("tireModel", 100);
/// The real inputs this test drives, with their value references and physics inputs.
const INPUTS: [(&str, u32, Input); 4] = [
    ("vx", 1, Input::Vx),
    ("vy", 2, Input::Vy),
    ("steerRate", 3, Input::SteerRate),
    ("vsx", 4, Input::Vsx),
];
/// Every output, with its value reference and physics output.
const OUTPUTS: [(&str, u32, Output); 9] = [
    ("Fx", 11, Output::Fx),
    ("Fy", 12, Output::Fy),
    ("Mz", 13, Output::Mz),
    ("My", 14, Output::My),
    ("alphaT", 15, Output::AlphaT),
    ("kappaT", 16, Output::KappaT),
    ("deflX", 17, Output::DeflX),
    ("deflY", 18, Output::DeflY),
    ("deflPsi", 19, Output::DeflPsi),
];

/// The packed FMU: `target/fmu/TireLag.fmu` (or the path in TIRELAG_FMU).
fn fmu_path() -> PathBuf {
    support::packed_artifact("TIRELAG_FMU", "target/fmu/TireLag.fmu")
}

/// Prints what the FMU sends to its logger callback (the `fmi` crate forwards it to `log`),
/// so a refused call shows its reason.
struct StderrLogger;

impl log::Log for StderrLogger {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.level() <= log::Level::Warn
    }

    fn log(&self, record: &log::Record) {
        if self.enabled(record.metadata()) {
            eprintln!("[{} {}] {}", record.level(), record.target(), record.args());
        }
    }

    fn flush(&self) {}
}

fn import() -> Fmi2Import {
    static LOGGER: Once = Once::new();
    LOGGER.call_once(|| {
        if log::set_logger(&StderrLogger).is_ok() {
            log::set_max_level(log::LevelFilter::Warn);
        }
    });
    let path = fmu_path();
    fmi::import::from_path(&path)
        .unwrap_or_else(|e| panic!("the fmi crate cannot import {}: {e} ({e:?})", path.display()))
}

/// Panics unless an FMI call returned fmi2OK.
fn ok(call: &str, result: Result<Fmi2Res, Fmi2Error>) {
    match result {
        Ok(Fmi2Res::OK) => {}
        other => panic!("{call} returned {other:?}, expected fmi2OK"),
    }
}

/// The inputs `[vx, vy, steerRate, vsx]` over step `k`: standing still for 0.2 s, then
/// rolling forward, through zero speed into reverse and forward again, while the other
/// inputs vary on their own time scales.
fn inputs_at(k: usize) -> [f64; 4] {
    let t = k as f64 * STEP_SIZE;
    let vx = if k < 20 {
        0.0
    } else {
        6.0 * (std::f64::consts::TAU * (t - 0.2) / 1.5).sin()
    };
    let vy = 0.3 * (3.1 * t).sin() + 0.05;
    let steer_rate = 0.2 * (5.3 * t).cos();
    let vsx = 0.1 * (2.3 * t).sin() - 0.02;
    [vx, vy, steer_rate, vsx]
}

/// Compares the outputs of the FMU (through the `fmi` crate) with the physics core at one
/// communication point; returns the largest relative difference.
fn compare(kind: ModelKind, step: usize, fmu: &[f64; 9], core: &[f64; 9]) -> f64 {
    let mut worst: f64 = 0.0;
    for ((name, _, _), (&a, &b)) in OUTPUTS.iter().zip(fmu.iter().zip(core)) {
        let scale = a.abs().max(b.abs()).max(1e-9);
        let relative = (a - b).abs() / scale;
        assert!(
            relative <= RELATIVE_TOLERANCE,
            "{} model, after {step} steps: {name} is {a:e} through the fmi crate but {b:e} in the \
             physics core (relative difference {relative:e})",
            kind.name()
        );
        worst = worst.max(relative);
    }
    worst
}

#[test]
fn fmi_crate_reads_the_model_description() {
    let import = import();
    let md = import.model_description();
    assert_eq!(md.fmi_version, "2.0");
    assert_eq!(md.model_name, "TireLag");
    assert_eq!(md.guid, tirelag::fmi::variables::GUID);
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
    let input_vrs = INPUTS.map(|(_, vr, _)| vr);
    let output_vrs = OUTPUTS.map(|(_, vr, _)| vr);
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

        let mut core = Tire::new(Parameters::default().with_model(kind)).expect("default parameters");
        let core_outputs = |tire: &mut Tire| {
            let y = tire.outputs();
            OUTPUTS.map(|(_, _, output)| y[output as usize])
        };

        let mut y = [0.0; 9];
        ok("fmi2GetReal(outputs)", fmu.get_real(&output_vrs, &mut y));
        let mut worst = compare(kind, 0, &y, &core_outputs(&mut core));
        let mut largest_fy: f64 = 0.0;
        for k in 0..STEPS {
            let u = inputs_at(k);
            ok("fmi2SetReal(inputs)", fmu.set_real(&input_vrs, &u));
            ok("fmi2DoStep", fmu.do_step(k as f64 * STEP_SIZE, STEP_SIZE, true));
            ok("fmi2GetReal(outputs)", fmu.get_real(&output_vrs, &mut y));

            for ((_, _, input), value) in INPUTS.iter().zip(u) {
                core.set_input(*input, value);
            }
            core.step(STEP_SIZE).expect("the physics core steps");
            worst = worst.max(compare(kind, k + 1, &y, &core_outputs(&mut core)));
            largest_fy = largest_fy.max(y[1].abs());
        }
        // The sequence must have driven the tire, or the comparison proves little.
        assert!(
            largest_fy > 1e3,
            "{} model: |Fy| stayed below {largest_fy} N",
            kind.name()
        );
        ok("fmi2Terminate", Common::terminate(&mut fmu));
        println!(
            "{}: {STEPS} steps through the fmi crate match the physics core; largest relative \
             difference {worst:e}, largest |Fy| {largest_fy:.1} N",
            kind.name()
        );
    }
}

/// The continuous states and event indicators of the FMU's Model Exchange interface.
const STATES: usize = 18;
const INDICATORS: usize = 9;
const MU_Y: (&str, u32) = ("muY", 123);
const FRICTION: (&str, u32) = ("friction", 121);
/// Substeps of the classical Runge-Kutta method per communication step.
const SUBSTEPS: usize = 100;

/// A Model Exchange instance integrated by the classical fourth-order Runge-Kutta method
/// with state events located by bisection on the substep: the importer's side of Model
/// Exchange, written here on the `fmi` crate's calls.
struct Integrator {
    fmu: fmi::fmi2::instance::Instance<fmi::ME>,
    time: f64,
    events: usize,
}

impl Integrator {
    fn rates(&mut self, t: f64, x: &[f64; STATES]) -> [f64; STATES] {
        ok("fmi2SetTime", self.fmu.set_time(t));
        ok("fmi2SetContinuousStates", self.fmu.set_continuous_states(x));
        let mut dx = [0.0; STATES];
        ok("fmi2GetDerivatives", self.fmu.get_derivatives(&mut dx));
        dx
    }

    fn indicators(&mut self, t: f64, x: &[f64; STATES]) -> [f64; INDICATORS] {
        ok("fmi2SetTime", self.fmu.set_time(t));
        ok("fmi2SetContinuousStates", self.fmu.set_continuous_states(x));
        let mut z = [0.0; INDICATORS];
        assert!(matches!(self.fmu.get_event_indicators(&mut z), Ok(true)));
        z
    }

    fn runge_kutta(&mut self, x: &[f64; STATES], h: f64) -> [f64; STATES] {
        let t = self.time;
        let along = |x: &[f64; STATES], k: &[f64; STATES], f: f64| -> [f64; STATES] {
            std::array::from_fn(|i| x[i] + f * h * k[i])
        };
        let k1 = self.rates(t, x);
        let k2 = self.rates(t + 0.5 * h, &along(x, &k1, 0.5));
        let k3 = self.rates(t + 0.5 * h, &along(x, &k2, 0.5));
        let k4 = self.rates(t + h, &along(x, &k3, 1.0));
        std::array::from_fn(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
    }

    fn event_update(&mut self) {
        ok("fmi2EnterEventMode", self.fmu.enter_event_mode());
        let mut flags = EventFlags::default();
        ok("fmi2NewDiscreteStates", self.fmu.new_discrete_states(&mut flags));
        assert!(!flags.discrete_states_need_update);
        ok(
            "fmi2EnterContinuousTimeMode",
            self.fmu.enter_continuous_time_mode(),
        );
    }

    /// Integrates over `h` with the inputs held; the inputs jumped at the start (an event).
    fn advance(&mut self, h: f64) {
        self.event_update();
        let end = self.time + h;
        let mut x = [0.0; STATES];
        ok("fmi2GetContinuousStates", self.fmu.get_continuous_states(&mut x));
        for substep in 0..SUBSTEPS {
            let until = self.time + h / SUBSTEPS as f64;
            let until = if substep + 1 == SUBSTEPS { end } else { until };
            loop {
                let length = until - self.time;
                if length <= 0.0 {
                    break;
                }
                let before = self.indicators(self.time, &x);
                let crossed =
                    |z: &[f64; INDICATORS]| before.iter().zip(z).any(|(b, a)| (*b > 0.0) != (*a > 0.0));
                let full = self.runge_kutta(&x, length);
                if !crossed(&self.indicators(until, &full)) {
                    x = full;
                    self.time = until;
                    break;
                }
                // The first crossing, to 1e-13 of the substep.
                let (mut inside, mut past) = (0.0, length);
                while past - inside > 1e-13 * length {
                    let middle = 0.5 * (inside + past);
                    let at = self.runge_kutta(&x, middle);
                    if crossed(&self.indicators(self.time + middle, &at)) {
                        past = middle;
                    } else {
                        inside = middle;
                    }
                }
                x = self.runge_kutta(&x, past);
                self.time += past;
                ok("fmi2SetContinuousStates", self.fmu.set_continuous_states(&x));
                self.events += 1;
                self.event_update();
                ok("fmi2GetContinuousStates", self.fmu.get_continuous_states(&mut x));
            }
        }
        ok("fmi2SetTime", self.fmu.set_time(self.time));
        ok("fmi2SetContinuousStates", self.fmu.set_continuous_states(&x));
    }
}

/// Every model with the Coulomb law at a low lateral limit (muY = 0.05: Fmax_y = 2.5 kN), so
/// that the input sequence above slides the tire in both directions: the Model Exchange
/// interface through the `fmi` crate, integrated by [`Integrator`], against the exact step
/// of the physics core at every communication point.
#[test]
fn fmi_crate_model_exchange_matches_the_exact_step_for_every_model() {
    let import = import();
    let input_vrs = INPUTS.map(|(_, vr, _)| vr);
    let output_vrs = OUTPUTS.map(|(_, vr, _)| vr);
    let mu = 0.05;
    for kind in ModelKind::ALL {
        let fmu = import
            .instantiate_me(&format!("fmi_importer_me_{}", kind.name()), false, true)
            .unwrap_or_else(|e| panic!("the fmi crate cannot instantiate the FMU: {e} ({e:?})"));
        let mut me = Integrator {
            fmu,
            time: 0.0,
            events: 0,
        };
        ok("fmi2SetupExperiment", me.fmu.setup_experiment(None, 0.0, None));
        ok(
            "fmi2SetInteger",
            me.fmu.set_integer(
                &[MODEL.1, FRICTION.1],
                &[kind as i32, FrictionLaw::Coulomb as i32],
            ),
        );
        ok("fmi2SetReal(muY)", me.fmu.set_real(&[MU_Y.1], &[mu]));
        ok(
            "fmi2EnterInitializationMode",
            Common::enter_initialization_mode(&mut me.fmu),
        );
        ok(
            "fmi2ExitInitializationMode",
            Common::exit_initialization_mode(&mut me.fmu),
        );
        ok("fmi2EnterContinuousTimeMode", {
            let mut flags = EventFlags::default();
            ok("fmi2NewDiscreteStates", me.fmu.new_discrete_states(&mut flags));
            me.fmu.enter_continuous_time_mode()
        });

        let mut parameters = Parameters::default().with_model(kind);
        parameters.friction = FrictionLaw::Coulomb;
        parameters
            .set(Parameter::LateralFriction, mu)
            .expect("a valid muY");
        let mut core = Tire::new(parameters).expect("valid parameters");
        let fmax = mu * core.input(Input::Fz);
        let mut worst: f64 = 0.0;
        let mut largest_fy: f64 = 0.0;
        for k in 0..STEPS {
            let u = inputs_at(k);
            ok("fmi2EnterEventMode", me.fmu.enter_event_mode());
            ok("fmi2SetReal(inputs)", me.fmu.set_real(&input_vrs, &u));
            me.advance(STEP_SIZE);
            let mut y = [0.0; 9];
            ok("fmi2GetReal(outputs)", me.fmu.get_real(&output_vrs, &mut y));

            for ((_, _, input), value) in INPUTS.iter().zip(u) {
                core.set_input(*input, value);
            }
            core.step(STEP_SIZE).expect("the physics core steps");
            let exact = core.outputs();
            for (name, index) in [("Fx", 0), ("Fy", 1)] {
                let difference = (y[index] - exact[OUTPUTS[index].2 as usize]).abs() / fmax;
                assert!(
                    difference <= 1e-6,
                    "{} model at {:.2} s: {name} {} through Model Exchange, {} exact ({difference:e} Fmax)",
                    kind.name(),
                    me.time,
                    y[index],
                    exact[OUTPUTS[index].2 as usize]
                );
                worst = worst.max(difference);
            }
            largest_fy = largest_fy.max(y[1].abs());
        }
        // (The contact-mass models' hub force adds the contact mass's inertia to the limited
        // tread force: it may pass the limit in transients.)
        assert!(
            largest_fy >= (1.0 - 1e-6) * fmax,
            "{} model: the tire must reach its limit ({largest_fy} N of {fmax} N)",
            kind.name()
        );
        assert!(
            me.events >= 2,
            "{} model: {} state events",
            kind.name(),
            me.events
        );
        println!(
            "{}: Model Exchange through the fmi crate, {} state events over {STEPS} steps; largest \
             difference from the exact step {worst:e} Fmax",
            kind.name(),
            me.events
        );
    }
}
