//! Model Exchange through the C ABI of the packed binary (docs/specification.md 7b): the call sequence, the
//! state vector and event indicators, events, FMU state and directional derivatives.
//! The agreement with Co-Simulation under a real solver is tested with fmpy
//! (tests/python/test_model_exchange.py) and with the `fmi` crate (tests/fmi_importer.rs).

mod support;

use fmi_sys::fmi2::*;
use support::{OK, Slave, load, messages, vr};

const STATES: usize = 18;
const INDICATORS: usize = 9;
const ERROR: fmi2Status = fmi2Status_fmi2Error;
/// Value references of the first continuous state and of its derivative.
const FIRST_STATE: u32 = 200;
const FIRST_DERIVATIVE: u32 = 300;
/// The state vector's value references, in its order (the model's six, then the offsets).
fn state_references() -> Vec<u32> {
    (0..6).chain(10..22).map(|k| FIRST_STATE + k).collect()
}

/// A Model Exchange instance in continuous-time mode, after the initial event.
fn running<'a>(
    fmu: &'a Fmi2Binding,
    name: &str,
    model: i32,
    friction: i32,
    reals: &[(u32, f64)],
) -> Slave<'a> {
    let slave = Slave::configured_as(
        fmu,
        name,
        fmi2Type_fmi2ModelExchange,
        &[(vr::MODEL, model), (vr::FRICTION, friction)],
        reals,
    );
    new_discrete_states(&slave);
    assert_eq!(unsafe { fmu.fmi2EnterContinuousTimeMode(slave.c) }, OK);
    slave
}

fn new_discrete_states(slave: &Slave) -> fmi2EventInfo {
    let mut info = unsafe { std::mem::zeroed::<fmi2EventInfo>() };
    assert_eq!(unsafe { slave.fmu.fmi2NewDiscreteStates(slave.c, &mut info) }, OK);
    assert_eq!(info.newDiscreteStatesNeeded, 0, "one update settles the modes");
    info
}

fn states(slave: &Slave) -> [f64; STATES] {
    let mut x = [0.0; STATES];
    assert_eq!(
        unsafe { slave.fmu.fmi2GetContinuousStates(slave.c, x.as_mut_ptr(), STATES) },
        OK
    );
    x
}

fn set_states(slave: &Slave, x: &[f64; STATES]) {
    assert_eq!(
        unsafe { slave.fmu.fmi2SetContinuousStates(slave.c, x.as_ptr(), STATES) },
        OK
    );
}

fn derivatives(slave: &Slave) -> [f64; STATES] {
    let mut dx = [0.0; STATES];
    assert_eq!(
        unsafe { slave.fmu.fmi2GetDerivatives(slave.c, dx.as_mut_ptr(), STATES) },
        OK
    );
    dx
}

fn indicators(slave: &Slave) -> [f64; INDICATORS] {
    let mut z = [0.0; INDICATORS];
    assert_eq!(
        unsafe {
            slave
                .fmu
                .fmi2GetEventIndicators(slave.c, z.as_mut_ptr(), INDICATORS)
        },
        OK
    );
    z
}

const INPUTS: [u32; 5] = [vr::VX, vr::VY, vr::STEER_RATE, vr::VSX, vr::FZ];

/// [`integrate_along`] with inputs held.
fn integrate(slave: &mut Slave, inputs: [f64; 5], h: f64, steps: usize) -> usize {
    integrate_along(slave, h, steps, |_| inputs)
}

/// Integrates by explicit Euler at `h` for `steps` steps with the inputs `inputs(t)` (vx,
/// vy, steerRate, vsx, Fz; t from the start), handling each state event as an importer
/// does (an indicator that changed sign: event mode, new discrete states, back). The
/// inputs jump at the start, so the importer goes through event mode there first (not
/// counted); then they move continuously. Returns the events.
fn integrate_along(slave: &mut Slave, h: f64, steps: usize, inputs: impl Fn(f64) -> [f64; 5]) -> usize {
    let fmu = slave.fmu;
    assert_eq!(unsafe { fmu.fmi2EnterEventMode(slave.c) }, OK);
    assert_eq!(slave.set_real(&INPUTS, &inputs(0.0)), OK);
    new_discrete_states(slave);
    assert_eq!(unsafe { fmu.fmi2EnterContinuousTimeMode(slave.c) }, OK);
    let mut before = indicators(slave);
    let mut events = 0;
    for step in 0..steps {
        let mut x = states(slave);
        let dx = derivatives(slave);
        for (state, rate) in x.iter_mut().zip(dx) {
            *state += h * rate;
        }
        slave.time += h;
        assert_eq!(unsafe { fmu.fmi2SetTime(slave.c, slave.time) }, OK);
        set_states(slave, &x);
        assert_eq!(slave.set_real(&INPUTS, &inputs((step + 1) as f64 * h)), OK);
        let after = indicators(slave);
        if before.iter().zip(&after).any(|(b, a)| (*b > 0.0) != (*a > 0.0)) {
            events += 1;
            assert_eq!(unsafe { fmu.fmi2EnterEventMode(slave.c) }, OK);
            new_discrete_states(slave);
            assert_eq!(unsafe { fmu.fmi2EnterContinuousTimeMode(slave.c) }, OK);
            before = indicators(slave);
        } else {
            before = after;
        }
    }
    events
}

#[test]
fn the_model_exchange_sequence_is_enforced() {
    let fmu = load();
    let me = Slave::configured_as(&fmu, "me_sequence", fmi2Type_fmi2ModelExchange, &[], &[]);
    // Initialised: event mode. States cannot be set, nor a step taken.
    let x = [0.0; STATES];
    assert_eq!(
        unsafe { fmu.fmi2SetContinuousStates(me.c, x.as_ptr(), STATES) },
        ERROR
    );
    assert!(
        messages("me_sequence")
            .join("\n")
            .contains("not allowed in event mode; it is allowed in continuous-time mode")
    );
    assert_eq!(unsafe { fmu.fmi2DoStep(me.c, 0.0, 1e-3, 1) }, ERROR);
    new_discrete_states(&me);
    assert_eq!(unsafe { fmu.fmi2EnterContinuousTimeMode(me.c) }, OK);
    let mut info = unsafe { std::mem::zeroed::<fmi2EventInfo>() };
    assert_eq!(unsafe { fmu.fmi2NewDiscreteStates(me.c, &mut info) }, ERROR);
    // Wrong lengths name both counts.
    let mut short = [0.0; 4];
    assert_eq!(
        unsafe { fmu.fmi2GetDerivatives(me.c, short.as_mut_ptr(), 4) },
        ERROR
    );
    assert!(
        messages("me_sequence")
            .join("\n")
            .contains("derivatives: 4 values were asked for, but the FMU has 18")
    );
    assert_eq!(
        unsafe { fmu.fmi2SetContinuousStates(me.c, x.as_ptr(), 17) },
        ERROR
    );
    let mut nan = x;
    nan[3] = f64::NAN;
    assert_eq!(
        unsafe { fmu.fmi2SetContinuousStates(me.c, nan.as_ptr(), STATES) },
        ERROR
    );
    assert!(
        messages("me_sequence")
            .join("\n")
            .contains("continuous state 4 is NaN")
    );
    // The error changed nothing.
    assert_eq!(states(&me), x);
    let (mut enter, mut terminate) = (1, 1);
    assert_eq!(
        unsafe { fmu.fmi2CompletedIntegratorStep(me.c, 1, &mut enter, &mut terminate) },
        OK
    );
    assert_eq!((enter, terminate), (0, 0));
    assert_eq!(unsafe { fmu.fmi2Terminate(me.c) }, OK);
    assert_eq!(unsafe { fmu.fmi2SetTime(me.c, 1.0) }, ERROR);

    // Model Exchange calls on a Co-Simulation instance are refused.
    let cs = Slave::configured(&fmu, "cs_no_me", &[], &[]);
    let mut dx = [0.0; STATES];
    assert_eq!(
        unsafe { fmu.fmi2GetDerivatives(cs.c, dx.as_mut_ptr(), STATES) },
        ERROR
    );
    assert_eq!(unsafe { fmu.fmi2SetTime(cs.c, 0.0) }, ERROR);
    assert!(
        messages("cs_no_me")
            .join("\n")
            .contains("this is a Model Exchange function; the instance was made for Co-Simulation")
    );
}

#[test]
fn states_and_derivatives_are_variables_too() {
    let fmu = load();
    for model in 1..=4 {
        let mut me = running(&fmu, "me_variables", model, 3, &[]);
        integrate(&mut me, [10.0, 0.2, 0.05, 0.1, 40_000.0], 1e-4, 100);
        let refs = state_references();
        assert_eq!(me.get_real(&refs), states(&me).to_vec());
        let derivative_refs: Vec<u32> = refs.iter().map(|r| r - FIRST_STATE + FIRST_DERIVATIVE).collect();
        assert_eq!(me.get_real(&derivative_refs), derivatives(&me).to_vec());
        // The model's own states move; slots past its count stay at zero.
        let count = [2, 3, 4, 6][model as usize - 1];
        let x = states(&me);
        assert!(x[..count].iter().all(|v| *v != 0.0), "model {model}: {x:?}");
        assert!(x[count..6].iter().all(|v| *v == 0.0), "model {model}: {x:?}");
        // States are set by fmi2SetContinuousStates only.
        assert_eq!(me.set_real(&[FIRST_STATE], &[0.1]), ERROR);
        let mut nominals = [0.0; STATES];
        assert_eq!(
            unsafe { fmu.fmi2GetNominalsOfContinuousStates(me.c, nominals.as_mut_ptr(), STATES) },
            OK
        );
        assert!(nominals.iter().all(|n| *n > 0.0 && n.is_finite()), "{nominals:?}");
    }
}

#[test]
fn a_slide_starts_and_ends_at_events_and_the_force_stays_on_its_limit() {
    let fmu = load();
    // Coulomb, muY = 0.02: Fmax_y = 1 kN. RLT pushed sideways at standstill: sticks until
    // the force reaches the limit (one event), slides on it, and sticks again when the
    // push reverses (a second event).
    let mu = 0.02;
    let mut me = running(&fmu, "me_slide", 1, 2, &[(vr::MU_Y, mu)]);
    let fmax = mu * 50_000.0;
    let events = integrate(&mut me, [0.0, 0.01, 0.0, 0.0, 50_000.0], 1e-3, 1000);
    assert_eq!(events, 1, "stick to slide");
    let fy = me.get_real(&[vr::FY])[0];
    assert!((fy + fmax).abs() <= 1e-6 * fmax, "on the limit: Fy = {fy}");
    // The push reverses (an input jump, taken in event mode): it sticks at once.
    let events = integrate(&mut me, [0.0, -0.01, 0.0, 0.0, 50_000.0], 1e-3, 10);
    assert_eq!(events, 0, "stuck when the push reversed");
    let fy = me.get_real(&[vr::FY])[0];
    assert!(fy > -fmax && fy < -0.9 * fmax, "unloading elastically: Fy = {fy}");
    // Pushed again, it slides again after 2 Fmax / C_y of travel: 0.2 s at 0.01 m/s.
    let events = integrate(&mut me, [0.0, 0.01, 0.0, 0.0, 50_000.0], 1e-3, 300);
    assert_eq!(events, 1, "stick to slide");
    // The load falls through zero and rises again: lift-off and touchdown are events, and
    // off the ground the force is zero.
    let load = |t: f64| 50_000.0 * (1.0 - 20.0 * t).abs() - 1_000.0;
    let events = integrate_along(&mut me, 1e-4, 500, |t| [0.0, 0.0, 0.0, 0.0, load(t)]);
    assert_eq!(me.get_real(&[vr::FY])[0], 0.0, "off the ground");
    assert_eq!(events, 1, "lift-off");
    let events = integrate_along(&mut me, 1e-4, 200, |t| [0.0, 0.0, 0.0, 0.0, load(0.05 + t)]);
    assert_eq!(events, 1, "touchdown");
}

/// An input event: the importer enters event mode, sets `inputs` and updates; whether the
/// update reported valuesOfContinuousStatesChanged.
fn input_event(slave: &Slave, inputs: [f64; 5]) -> bool {
    assert_eq!(unsafe { slave.fmu.fmi2EnterEventMode(slave.c) }, OK);
    assert_eq!(slave.set_real(&INPUTS, &inputs), OK);
    let info = new_discrete_states(slave);
    assert_eq!(unsafe { slave.fmu.fmi2EnterContinuousTimeMode(slave.c) }, OK);
    info.valuesOfContinuousStatesChanged != 0
}

/// The rates jump wherever a mode or an input changes, so the event update says so
/// (valuesOfContinuousStatesChanged), and an importer that keeps a solver history (fmusim
/// with CVode restarts only then) starts again; where nothing changed it says nothing.
#[test]
fn the_event_update_reports_every_change_of_mode_or_input_and_only_those() {
    let fmu = load();
    let mu = 0.02;
    let mut me = running(&fmu, "me_restart", 1, 2, &[(vr::MU_Y, mu)]);
    let push = [0.0, 0.01, 0.0, 0.0, 50_000.0];
    assert!(input_event(&me, push), "an input event: the push starts");
    assert!(!input_event(&me, push), "an event at which nothing changed");

    // A state event: the push brings the force to its limit and the tire slides.
    let mut before = indicators(&me);
    let mut changed = None;
    for _ in 0..1000 {
        let mut x = states(&me);
        for (state, rate) in x.iter_mut().zip(derivatives(&me)) {
            *state += 1e-3 * rate;
        }
        me.time += 1e-3;
        assert_eq!(unsafe { fmu.fmi2SetTime(me.c, me.time) }, OK);
        set_states(&me, &x);
        let after = indicators(&me);
        if before.iter().zip(&after).any(|(b, a)| (*b > 0.0) != (*a > 0.0)) {
            assert_eq!(unsafe { fmu.fmi2EnterEventMode(me.c) }, OK);
            changed = Some(new_discrete_states(&me).valuesOfContinuousStatesChanged != 0);
            assert_eq!(unsafe { fmu.fmi2EnterContinuousTimeMode(me.c) }, OK);
            break;
        }
        before = after;
    }
    assert_eq!(changed, Some(true), "stick to slide reported");
    assert!(!input_event(&me, push), "still sliding, the same push");

    // Input events that change the contact: lift-off, nothing, touchdown.
    let lifted = [0.0, 0.01, 0.0, 0.0, -1_000.0];
    assert!(input_event(&me, lifted), "lift-off reported");
    assert!(!input_event(&me, lifted), "still off the ground, the same inputs");
    assert!(
        input_event(&me, [0.0, 0.0, 0.0, 0.0, 50_000.0]),
        "touchdown reported"
    );
    assert!(
        input_event(&me, [0.0, 0.0, 0.0, 0.0, 60_000.0]),
        "a larger load, no mode changed: an input did"
    );
}

#[test]
fn the_fmu_state_carries_the_modes_across_a_serialization() {
    let fmu = load();
    let mut me = running(&fmu, "me_state", 2, 3, &[(vr::MU_X, 0.05), (vr::MU_Y, 0.05)]);
    integrate(&mut me, [3.0, 0.3, 0.2, 0.1, 50_000.0], 1e-4, 300);
    let mut state: fmi2FMUstate = std::ptr::null_mut();
    assert_eq!(unsafe { fmu.fmi2GetFMUstate(me.c, &mut state) }, OK);
    let mut size = 0;
    assert_eq!(
        unsafe { fmu.fmi2SerializedFMUstateSize(me.c, state, &mut size) },
        OK
    );
    let mut bytes = vec![0u8; size];
    assert_eq!(
        unsafe { fmu.fmi2SerializeFMUstate(me.c, state, bytes.as_mut_ptr().cast(), size) },
        OK
    );
    let expected = (states(&me), derivatives(&me), indicators(&me));
    integrate(&mut me, [3.0, -0.3, 0.2, 0.1, 50_000.0], 1e-4, 300);
    assert_ne!(states(&me), expected.0);

    // Another instance, from the bytes: the same states, modes and so derivatives.
    let other = Slave::configured_as(&fmu, "me_state_other", fmi2Type_fmi2ModelExchange, &[], &[]);
    let mut restored: fmi2FMUstate = std::ptr::null_mut();
    assert_eq!(
        unsafe { fmu.fmi2DeSerializeFMUstate(other.c, bytes.as_ptr().cast(), size, &mut restored) },
        OK
    );
    assert_eq!(unsafe { fmu.fmi2SetFMUstate(other.c, restored) }, OK);
    assert_eq!(
        (states(&other), derivatives(&other), indicators(&other)),
        expected
    );
    // A Co-Simulation instance does not take a Model Exchange state.
    let cs = Slave::configured(&fmu, "cs_state", &[], &[]);
    assert_eq!(unsafe { fmu.fmi2SetFMUstate(cs.c, restored) }, ERROR);
    assert!(
        messages("cs_state")
            .join("\n")
            .contains("taken from a Model Exchange instance")
    );
    for mut s in [state, restored] {
        assert_eq!(unsafe { fmu.fmi2FreeFMUstate(me.c, &mut s) }, OK);
    }
}

/// The directional derivative along each state and input against a central difference of
/// the derivatives the FMU gives, while every branch sticks (exact there: the rates are
/// linear) and while one slides (a difference there too, of the law in its mode).
#[test]
fn directional_derivatives_of_the_rates_match_their_differences() {
    let fmu = load();
    for model in 1..=4 {
        for (mu, label) in [(0.8, "sticking"), (0.01, "sliding")] {
            let mut me = running(&fmu, "me_jacobian", model, 2, &[(vr::MU_X, mu), (vr::MU_Y, mu)]);
            let inputs = [5.0, 0.05, 0.1, 0.02, 45_000.0];
            let events = integrate(&mut me, inputs, 1e-4, 1000);
            assert_eq!(events > 0, mu < 0.1, "model {model} {label}: {events} events");
            let x = states(&me);
            let rates = derivatives(&me);
            let derivative_refs: Vec<u32> = state_references()
                .iter()
                .map(|r| r - FIRST_STATE + FIRST_DERIVATIVE)
                .collect();
            let knowns: Vec<(u32, f64)> = state_references()
                .into_iter()
                .zip(x)
                .chain([(vr::VX, 5.0), (vr::VY, 0.05), (vr::VSX, 0.02), (vr::FZ, 45_000.0)])
                .collect();
            for (known, value) in knowns {
                let mut column = [0.0; STATES];
                let seed = [1.0];
                assert_eq!(
                    unsafe {
                        fmu.fmi2GetDirectionalDerivative(
                            me.c,
                            derivative_refs.as_ptr(),
                            STATES,
                            &known,
                            1,
                            seed.as_ptr(),
                            column.as_mut_ptr(),
                        )
                    },
                    OK
                );
                let delta = 1e-6 * value.abs().max(if known == vr::FZ { 1e3 } else { 1e-3 });
                let at = |shift: f64| {
                    if known >= FIRST_STATE {
                        let mut moved = x;
                        let k = state_references().iter().position(|r| *r == known).unwrap();
                        moved[k] += shift;
                        set_states(&me, &moved);
                    } else {
                        assert_eq!(me.set_real(&[known], &[value + shift]), OK);
                    }
                    let rates = derivatives(&me);
                    if known >= FIRST_STATE {
                        set_states(&me, &x);
                    } else {
                        assert_eq!(me.set_real(&[known], &[value]), OK);
                    }
                    rates
                };
                let (plus, minus) = (at(delta), at(-delta));
                // Rounding of the rates over the difference's step.
                let rounding = 1e-12 * rates.iter().fold(0.0_f64, |m, r| m.max(r.abs())) / delta;
                for k in 0..STATES {
                    let difference = (plus[k] - minus[k]) / (2.0 * delta);
                    assert!(
                        (column[k] - difference).abs() <= 1e-5 * difference.abs() + rounding,
                        "model {model} {label}, d der[{k}] / d {known}: {} against {difference}",
                        column[k]
                    );
                }
            }
        }
    }
}
