//! What the tests of the packed FMUs through the `fmi` crate share: tests/fmi_importer.rs
//! (FMI 2.0) and tests/fmi3_importer.rs (FMI 3.0) drive the same binary through the
//! crate's two importers with the same input sequence, compare it with the same physics
//! core, and integrate Model Exchange with the same solver, written on the crate's
//! version-independent [`FmiModelExchange`] trait.

use std::fmt::Debug;
use std::sync::Once;

use fmi::EventFlags;
use fmi::fmi2::{Fmi2Error, Fmi2Res};
use fmi::fmi3::{Fmi3Error, Fmi3Res};
use fmi::traits::{FmiModelExchange, InstanceResult};
use tirelag::physics::{FrictionLaw, Input, ModelKind, Output, Parameter, Parameters, Tire};

pub const STEP_SIZE: f64 = 0.01;
pub const STEPS: usize = 200;
/// The packed binary and this test's build of the core are two compilations of the same
/// code: with the default Brush law the adaptive sliding integration can round
/// differently between them, far below its 1e-12 accuracy per substep.
pub const RELATIVE_TOLERANCE: f64 = 1e-10;
/// The difference allowed between Model Exchange, integrated by [`Integrator`], and the
/// exact step of the core, in units of the friction limit: RK4 on 1e-4 s substeps with
/// the mode changes located to 1e-13 of a substep.
pub const MODEL_EXCHANGE_TOLERANCE: f64 = 1e-6;

pub const MODEL: (&str, u32) = ("tireModel", 100);
pub const FRICTION: (&str, u32) = ("friction", 121);
pub const MU_Y: (&str, u32) = ("muY", 123);
/// The lateral friction coefficient of the Model Exchange runs (Fmax_y = 2.5 kN at the
/// nominal load): low enough that [`inputs_at`] slides the tire in both directions.
pub const SLIDING_MU: f64 = 0.05;
/// The real inputs the tests drive, with their value references and physics inputs.
pub const INPUTS: [(&str, u32, Input); 4] = [
    ("vx", 1, Input::Vx),
    ("vy", 2, Input::Vy),
    ("steerRate", 3, Input::SteerRate),
    ("vsx", 4, Input::Vsx),
];
/// Every output, with its value reference and physics output.
pub const OUTPUTS: [(&str, u32, Output); 9] = [
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
/// The continuous states and event indicators of the FMU's Model Exchange interface.
pub const STATES: usize = 18;
pub const INDICATORS: usize = 9;
/// Substeps of the classical Runge-Kutta method per communication step.
const SUBSTEPS: usize = 100;

/// The value references of [`INPUTS`] and of [`OUTPUTS`].
pub fn input_references() -> [u32; 4] {
    INPUTS.map(|(_, vr, _)| vr)
}

pub fn output_references() -> [u32; 9] {
    OUTPUTS.map(|(_, vr, _)| vr)
}

/// Prints what the FMU sends to its logger callback (the `fmi` crate forwards it to `log`),
/// so that a refused call shows its reason.
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

pub fn install_logger() {
    static LOGGER: Once = Once::new();
    LOGGER.call_once(|| {
        if log::set_logger(&StderrLogger).is_ok() {
            log::set_max_level(log::LevelFilter::Warn);
        }
    });
}

/// What the crate's calls return, in either FMI version.
pub trait Outcome: Debug {
    /// The status the tests expect, as the standard names it.
    const OK: &'static str;

    fn is_ok(&self) -> bool;
}

impl Outcome for Result<Fmi2Res, Fmi2Error> {
    const OK: &'static str = "fmi2OK";

    fn is_ok(&self) -> bool {
        matches!(self, Ok(Fmi2Res::OK))
    }
}

impl Outcome for Result<Fmi3Res, Fmi3Error> {
    const OK: &'static str = "fmi3OK";

    fn is_ok(&self) -> bool {
        matches!(self, Ok(Fmi3Res::OK))
    }
}

/// Panics unless a call returned OK (a warning fails too).
pub fn ok<R: Outcome>(call: &str, result: R) {
    assert!(result.is_ok(), "{call} returned {result:?}, expected {}", R::OK);
}

/// The inputs `[vx, vy, steerRate, vsx]` over step `k`: standing still for 0.2 s, then
/// rolling forward, through zero speed into reverse and forward again, while the other
/// inputs vary on their own time scales.
pub fn inputs_at(k: usize) -> [f64; 4] {
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

fn set_core_inputs(tire: &mut Tire, u: [f64; 4]) {
    for ((_, _, input), value) in INPUTS.iter().zip(u) {
        tire.set_input(*input, value);
    }
}

fn core_outputs(tire: &mut Tire) -> [f64; 9] {
    let y = tire.outputs();
    OUTPUTS.map(|(_, _, output)| y[output as usize])
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

/// A Co-Simulation run of `kind` over [`STEPS`] steps of [`inputs_at`] against the physics
/// core stepped directly, with piecewise-constant inputs in both: `initial` are the FMU's
/// outputs after initialisation, and `step(k, u)` sets the inputs `u`, steps the FMU from
/// `k * STEP_SIZE` by [`STEP_SIZE`] and returns its outputs.
pub fn co_simulation_matches_the_core(
    kind: ModelKind,
    initial: [f64; 9],
    mut step: impl FnMut(usize, [f64; 4]) -> [f64; 9],
) {
    let mut core = Tire::new(Parameters::default().with_model(kind)).expect("default parameters");
    let mut worst = compare(kind, 0, &initial, &core_outputs(&mut core));
    let mut largest_fy: f64 = 0.0;
    for k in 0..STEPS {
        let u = inputs_at(k);
        let y = step(k, u);
        set_core_inputs(&mut core, u);
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
    println!(
        "{}: {STEPS} steps through the fmi crate match the physics core; largest relative \
         difference {worst:e}, largest |Fy| {largest_fy:.1} N",
        kind.name()
    );
}

/// A Model Exchange instance integrated by the classical fourth-order Runge-Kutta method
/// with state events located by bisection on the substep: the importer's side of Model
/// Exchange, on the `fmi` crate's calls common to FMI 2.0 and FMI 3.0.
pub struct Integrator<I> {
    pub fmu: I,
    pub time: f64,
    /// State events met (mode changes inside a step; the input jumps are not counted).
    pub events: usize,
}

impl<I> Integrator<I>
where
    I: FmiModelExchange,
    InstanceResult<I>: Outcome,
{
    /// Takes over an instance in Event Mode at time 0 (just initialised) and leaves that
    /// event.
    pub fn new(fmu: I) -> Self {
        let mut me = Integrator {
            fmu,
            time: 0.0,
            events: 0,
        };
        me.leave_event_mode();
        me
    }

    /// The event iteration (one pass: the FMU has no discrete states to iterate on), then
    /// Continuous-Time Mode.
    fn leave_event_mode(&mut self) {
        let mut flags = EventFlags::default();
        ok(
            "update_discrete_states",
            self.fmu.update_discrete_states(&mut flags),
        );
        assert!(
            !flags.discrete_states_need_update && !flags.terminate_simulation,
            "after an event: {flags:?}"
        );
        ok(
            "enter_continuous_time_mode",
            self.fmu.enter_continuous_time_mode(),
        );
    }

    fn set(&mut self, t: f64, x: &[f64; STATES]) {
        ok("set_time", self.fmu.set_time(t));
        ok("set_continuous_states", self.fmu.set_continuous_states(x));
    }

    fn rates(&mut self, t: f64, x: &[f64; STATES]) -> [f64; STATES] {
        self.set(t, x);
        let mut dx = [0.0; STATES];
        ok(
            "get_continuous_state_derivatives",
            self.fmu.get_continuous_state_derivatives(&mut dx),
        );
        dx
    }

    fn indicators(&mut self, t: f64, x: &[f64; STATES]) -> [f64; INDICATORS] {
        self.set(t, x);
        let mut z = [0.0; INDICATORS];
        let result = self.fmu.get_event_indicators(&mut z);
        assert!(
            matches!(result, Ok(true)),
            "get_event_indicators returned {result:?}"
        );
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

    /// Integrates over `h` with the inputs held. The FMU is in Event Mode: the inputs
    /// jumped at the start.
    pub fn advance(&mut self, h: f64) {
        self.leave_event_mode();
        let end = self.time + h;
        let mut x = [0.0; STATES];
        ok("get_continuous_states", self.fmu.get_continuous_states(&mut x));
        for substep in 0..SUBSTEPS {
            let until = if substep + 1 == SUBSTEPS {
                end
            } else {
                self.time + h / SUBSTEPS as f64
            };
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
                self.set(self.time, &x);
                self.events += 1;
                ok("enter_event_mode", self.fmu.enter_event_mode());
                self.leave_event_mode();
                ok("get_continuous_states", self.fmu.get_continuous_states(&mut x));
            }
        }
        self.set(self.time, &x);
    }
}

/// A Model Exchange run of `kind` with the Coulomb law at `muY` = [`SLIDING_MU`], so that
/// [`inputs_at`] slides the tire in both directions: `fmu`, given those parameters and
/// initialised (in Event Mode at time 0), integrated by [`Integrator`] with the inputs
/// `set_inputs` writes (in Event Mode) and the outputs `outputs` reads, against the exact
/// step of the physics core at every communication point.
pub fn model_exchange_matches_the_exact_step<I>(
    kind: ModelKind,
    fmu: I,
    mut set_inputs: impl FnMut(&mut I, &[f64; 4]),
    mut outputs: impl FnMut(&mut I) -> [f64; 9],
) where
    I: FmiModelExchange,
    InstanceResult<I>: Outcome,
{
    let mut me = Integrator::new(fmu);
    let mut parameters = Parameters::default().with_model(kind);
    parameters.friction = FrictionLaw::Coulomb;
    parameters
        .set(Parameter::LateralFriction, SLIDING_MU)
        .expect("a valid muY");
    let mut core = Tire::new(parameters).expect("valid parameters");
    let fmax = SLIDING_MU * core.input(Input::Fz);
    let mut worst: f64 = 0.0;
    let mut largest_fy: f64 = 0.0;
    for k in 0..STEPS {
        let u = inputs_at(k);
        ok("enter_event_mode", me.fmu.enter_event_mode());
        set_inputs(&mut me.fmu, &u);
        me.advance(STEP_SIZE);
        let y = outputs(&mut me.fmu);

        set_core_inputs(&mut core, u);
        core.step(STEP_SIZE).expect("the physics core steps");
        let exact = core_outputs(&mut core);
        for (name, index) in [("Fx", 0), ("Fy", 1)] {
            let exact = exact[index];
            let difference = (y[index] - exact).abs() / fmax;
            assert!(
                difference <= MODEL_EXCHANGE_TOLERANCE,
                "{} model at {:.2} s: {name} {} through Model Exchange, {exact} exact \
                 ({difference:e} Fmax)",
                kind.name(),
                me.time,
                y[index],
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
    ok("terminate", me.fmu.terminate());
    println!(
        "{}: Model Exchange through the fmi crate, {} state events over {STEPS} steps; largest \
         difference from the exact step {worst:e} Fmax",
        kind.name(),
        me.events
    );
}
