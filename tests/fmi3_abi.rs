//! The FMI 3.0 C ABI of the packed binary, driven like an importer: every function is
//! exported; Co-Simulation and Model Exchange give bit for bit what the FMI 2.0 functions
//! of the same library give; the call sequence, bad input and what this FMU does not
//! provide are refused with a message that names the call; FMU states round trip through
//! bytes. Run under valgrind by ./scripts/memcheck with the FMI 2.0 C-ABI tests.

mod support;

use std::ffi::{CString, c_void};
use std::ptr::{null, null_mut};

use fmi_sys::fmi3::*;
use support::fmi3::{ERROR, Instance3, Kind, NO_INSTANCE, OK, load, log_message};
use support::{GUID, Slave, vr};

/// Every function of fmi3Functions.h (FMI 3.0).
const FUNCTIONS: &str = "fmi3GetVersion fmi3SetDebugLogging fmi3InstantiateModelExchange \
    fmi3InstantiateCoSimulation fmi3InstantiateScheduledExecution fmi3FreeInstance \
    fmi3EnterInitializationMode fmi3ExitInitializationMode fmi3EnterEventMode fmi3Terminate fmi3Reset \
    fmi3GetFloat32 fmi3GetFloat64 fmi3GetInt8 fmi3GetUInt8 fmi3GetInt16 fmi3GetUInt16 fmi3GetInt32 \
    fmi3GetUInt32 fmi3GetInt64 fmi3GetUInt64 fmi3GetBoolean fmi3GetString fmi3GetBinary fmi3GetClock \
    fmi3SetFloat32 fmi3SetFloat64 fmi3SetInt8 fmi3SetUInt8 fmi3SetInt16 fmi3SetUInt16 fmi3SetInt32 \
    fmi3SetUInt32 fmi3SetInt64 fmi3SetUInt64 fmi3SetBoolean fmi3SetString fmi3SetBinary fmi3SetClock \
    fmi3GetNumberOfVariableDependencies fmi3GetVariableDependencies fmi3GetFMUState fmi3SetFMUState \
    fmi3FreeFMUState fmi3SerializedFMUStateSize fmi3SerializeFMUState fmi3DeserializeFMUState \
    fmi3GetDirectionalDerivative fmi3GetAdjointDerivative fmi3EnterConfigurationMode \
    fmi3ExitConfigurationMode fmi3GetIntervalDecimal fmi3GetIntervalFraction fmi3GetShiftDecimal \
    fmi3GetShiftFraction fmi3SetIntervalDecimal fmi3SetIntervalFraction fmi3SetShiftDecimal \
    fmi3SetShiftFraction fmi3EvaluateDiscreteStates fmi3UpdateDiscreteStates fmi3EnterContinuousTimeMode \
    fmi3CompletedIntegratorStep fmi3SetTime fmi3SetContinuousStates fmi3GetContinuousStateDerivatives \
    fmi3GetEventIndicators fmi3GetContinuousStates fmi3GetNominalsOfContinuousStates \
    fmi3GetNumberOfEventIndicators fmi3GetNumberOfContinuousStates fmi3EnterStepMode \
    fmi3GetOutputDerivatives fmi3DoStep fmi3ActivateModelPartition";

const INPUTS: [u32; 5] = [vr::VX, vr::VY, vr::STEER_RATE, vr::VSX, vr::FZ];

#[test]
fn every_fmi3_function_is_exported() {
    let library = unsafe { libloading::Library::new(support::binary_path()) }.unwrap();
    let names: Vec<&str> = FUNCTIONS.split_whitespace().collect();
    assert_eq!(names.len(), 75, "FMI 3.0 has 75 functions");
    for name in names {
        let symbol = unsafe { library.get::<*const c_void>(name.as_bytes()) };
        assert!(symbol.is_ok(), "{name} is not exported");
    }
    let fmu = load();
    let version = unsafe { std::ffi::CStr::from_ptr(fmu.fmi3GetVersion()) };
    assert_eq!(version.to_str().unwrap(), "3.0");
}

/// The inputs of step `k`: a slip that saturates the limit back and forth, through
/// standstill, with the load swinging.
fn inputs_at(k: usize) -> [f64; 5] {
    let t = k as f64 * 0.01;
    [
        2.0 * (0.5 * t).cos(),
        0.3 * (1.3 * t).sin(),
        0.2 * (0.7 * t).cos(),
        0.1 * (0.9 * t).sin(),
        40_000.0 * (1.0 + 0.3 * (0.4 * t).sin()),
    ]
}

#[test]
fn co_simulation_gives_the_fmi2_bits_for_every_model_and_law() {
    let (fmu2, fmu3) = (support::load(), load());
    for model in 1..=4 {
        for friction in 1..=3 {
            let reals = [(vr::MU_X, 0.1), (vr::MU_Y, 0.1)];
            let name = format!("fmi3_cs_{model}_{friction}");
            let mut two = Slave::configured(
                &fmu2,
                &format!("{name}_2"),
                &[(vr::MODEL, model), (vr::FRICTION, friction)],
                &reals,
            );
            let mut three = Instance3::initialised(
                &fmu3,
                &name,
                Kind::CoSimulation,
                [model.into(), friction.into()],
                &reals,
            );
            for k in 0..300 {
                let inputs = inputs_at(k);
                assert_eq!(two.set_real(&INPUTS, &inputs), support::OK);
                assert_eq!(three.set_float64(&INPUTS, &inputs), OK);
                assert_eq!(two.step(0.01), support::OK);
                assert_eq!(three.step(0.01), OK, "{}", three.log());
                let (a, b) = (two.outputs(), three.get_float64(&vr::OUTPUTS));
                assert!(
                    a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
                    "model {model}, friction {friction}, step {k}: FMI 2.0 {a:?}, FMI 3.0 {b:?}"
                );
            }
            assert_eq!(three.get_float64(&[0]), [three.time], "time");
        }
    }
}

#[test]
fn model_exchange_gives_the_fmi2_derivatives_and_indicators() {
    let (fmu2, fmu3) = (support::load(), load());
    for model in 1..=4 {
        let reals = [(vr::MU_X, 0.05), (vr::MU_Y, 0.05)];
        let name = format!("fmi3_me_{model}");
        let two = Slave::configured_as(
            &fmu2,
            &format!("{name}_2"),
            fmi_sys::fmi2::fmi2Type_fmi2ModelExchange,
            &[(vr::MODEL, model), (vr::FRICTION, 3)],
            &reals,
        );
        let three = Instance3::initialised(&fmu3, &name, Kind::ModelExchange, [model.into(), 3], &reals);
        let mut info = unsafe { std::mem::zeroed::<fmi_sys::fmi2::fmi2EventInfo>() };
        assert_eq!(
            unsafe { fmu2.fmi2NewDiscreteStates(two.c, &mut info) },
            support::OK
        );
        three.update_discrete_states();
        assert_eq!(unsafe { fmu2.fmi2EnterContinuousTimeMode(two.c) }, support::OK);
        assert_eq!(unsafe { fmu3.fmi3EnterContinuousTimeMode(three.c) }, OK);
        // Explicit Euler through both interfaces, with events where an indicator crosses.
        let mut x = vec![0.0; 18];
        let mut before: Option<Vec<f64>> = None;
        let mut events = 0;
        for k in 0..2000 {
            let t = k as f64 * 1e-3;
            let inputs = inputs_at(k / 10);
            assert_eq!(two.set_real(&INPUTS, &inputs), support::OK);
            assert_eq!(three.set_float64(&INPUTS, &inputs), OK);
            unsafe {
                assert_eq!(fmu2.fmi2SetTime(two.c, t), support::OK);
                assert_eq!(fmu3.fmi3SetTime(three.c, t), OK);
                assert_eq!(fmu2.fmi2SetContinuousStates(two.c, x.as_ptr(), 18), support::OK);
                assert_eq!(fmu3.fmi3SetContinuousStates(three.c, x.as_ptr(), 18), OK);
            }
            let (mut dx, mut z) = three.evaluate();
            let (mut dx2, mut z2) = (vec![0.0; 18], vec![0.0; 9]);
            unsafe {
                assert_eq!(fmu2.fmi2GetDerivatives(two.c, dx2.as_mut_ptr(), 18), support::OK);
                assert_eq!(
                    fmu2.fmi2GetEventIndicators(two.c, z2.as_mut_ptr(), 9),
                    support::OK
                );
            }
            assert_eq!((&dx, &z), (&dx2, &z2), "model {model}, t = {t}");
            assert_eq!(
                three.get_float64(&[400, 401, 402, 403, 404, 405, 406, 407, 408]),
                z
            );
            if before
                .as_ref()
                .is_some_and(|b| b.iter().zip(&z).any(|(p, q)| (*p > 0.0) != (*q > 0.0)))
            {
                events += 1;
                unsafe {
                    assert_eq!(fmu2.fmi2EnterEventMode(two.c), support::OK);
                    assert_eq!(fmu3.fmi3EnterEventMode(three.c), OK);
                    assert_eq!(fmu2.fmi2NewDiscreteStates(two.c, &mut info), support::OK);
                }
                assert_eq!(
                    three.update_discrete_states(),
                    info.valuesOfContinuousStatesChanged != 0
                );
                unsafe {
                    assert_eq!(fmu2.fmi2EnterContinuousTimeMode(two.c), support::OK);
                    assert_eq!(fmu3.fmi3EnterContinuousTimeMode(three.c), OK);
                    assert_eq!(fmu3.fmi3GetContinuousStates(three.c, x.as_mut_ptr(), 18), OK);
                }
                (dx, z) = three.evaluate();
            }
            before = Some(z);
            for (state, rate) in x.iter_mut().zip(&dx) {
                *state += 1e-3 * rate;
            }
        }
        assert!(events > 0, "model {model}: the friction limit must act");
        assert!(x.iter().all(|v| v.is_finite()));
    }
}

#[test]
fn the_call_sequence_and_bad_input_are_refused_naming_the_call() {
    let fmu = load();
    let mut cs = Instance3::instantiate(&fmu, "fmi3_sequence", Kind::CoSimulation);
    assert_eq!(cs.step(0.01), ERROR, "no step before initialisation");
    assert!(
        cs.log()
            .contains("fmi3DoStep: this call is not allowed in instantiated"),
        "{}",
        cs.log()
    );
    let model = [vr::MODEL];
    assert_eq!(cs.set_int64(&model, &[5]), ERROR, "no fifth model");
    assert_eq!(cs.set_int64(&model, &[1 << 40]), ERROR, "far out of range");
    assert_eq!(cs.set_int64(&model, &[1]), OK);
    let mut value = [0i64];
    assert_eq!(
        unsafe { fmu.fmi3GetInt64(cs.c, model.as_ptr(), 1, value.as_mut_ptr(), 1) },
        ERROR,
        "before initialisation"
    );
    assert_eq!(
        unsafe { fmu.fmi3EnterInitializationMode(cs.c, false, 0.0, 0.0, true, 1.0) },
        OK
    );
    assert_eq!(
        unsafe { fmu.fmi3GetInt64(cs.c, model.as_ptr(), 1, value.as_mut_ptr(), 1) },
        OK
    );
    assert_eq!(value, [1]);
    let mut selector = [0i32];
    let status = unsafe { fmu.fmi3GetInt32(cs.c, model.as_ptr(), 1, selector.as_mut_ptr(), 1) };
    assert_eq!(status, ERROR, "an Enumeration is read as Int64");
    assert!(
        cs.log().contains(
            "fmi3GetInt32: this FMU has no variables of that type; value reference 100 is tireModel"
        ),
        "{}",
        cs.log()
    );
    assert_eq!(unsafe { fmu.fmi3ExitInitializationMode(cs.c) }, OK);
    assert_eq!(cs.set_float64(&[vr::VX], &[f64::NAN]), ERROR);
    assert_eq!(cs.set_float64(&[vr::VX], &[2000.0]), ERROR, "above the maximum");
    let two_values = [1.0, 2.0];
    let status = unsafe { fmu.fmi3SetFloat64(cs.c, [vr::VX].as_ptr(), 1, two_values.as_ptr(), 2) };
    assert_eq!(status, ERROR, "two values for one scalar");
    assert_eq!(cs.get_float64(&[vr::VX]), [0.0], "nothing changed");
    assert_eq!(unsafe { fmu.fmi3EnterStepMode(cs.c) }, ERROR);
    assert_eq!(unsafe { fmu.fmi3EnterEventMode(cs.c) }, ERROR);
    assert_eq!(unsafe { fmu.fmi3EnterConfigurationMode(cs.c) }, ERROR);
    let no_seed =
        unsafe { fmu.fmi3GetAdjointDerivative(cs.c, null(), 0, null(), 0, null(), 0, null_mut(), 0) };
    assert_eq!(no_seed, ERROR);
    let log = cs.log();
    for call in [
        "fmi3EnterStepMode",
        "fmi3EnterEventMode",
        "fmi3EnterConfigurationMode",
        "fmi3GetAdjointDerivative",
    ] {
        assert!(log.contains(&format!("{call}: ")), "{call} says why: {log}");
    }
    for _ in 0..100 {
        assert_eq!(cs.step(0.01), OK);
    }
    assert_eq!(cs.step(0.01), ERROR, "past stopTime");
    assert!(cs.log().contains("past stopTime"));
    // A null handle is refused by every kind of call, not followed.
    unsafe {
        assert_eq!(fmu.fmi3Terminate(NO_INSTANCE), ERROR);
        assert_eq!(fmu.fmi3SetTime(NO_INSTANCE, 0.0), ERROR);
        fmu.fmi3FreeInstance(NO_INSTANCE);
    }
}

#[test]
fn instantiation_refuses_what_this_fmu_does_not_provide() {
    let fmu = load();
    let name = CString::new("fmi3_refused").unwrap();
    let environment = name.as_ptr().cast_mut().cast::<c_void>();
    let token = CString::new(GUID).unwrap();
    let co_simulation = |token: &CString, event_mode: bool| unsafe {
        fmu.fmi3InstantiateCoSimulation(
            name.as_ptr(),
            token.as_ptr(),
            null(),
            false,
            false,
            event_mode,
            false,
            null(),
            0,
            environment,
            Some(log_message),
            None,
        )
    };
    assert!(
        co_simulation(&token, true).is_null(),
        "event mode in Co-Simulation"
    );
    assert!(co_simulation(&CString::new("{not-the-token}").unwrap(), false).is_null());
    let scheduled = unsafe {
        fmu.fmi3InstantiateScheduledExecution(
            name.as_ptr(),
            token.as_ptr(),
            null(),
            false,
            false,
            environment,
            Some(log_message),
            None,
            None,
            None,
        )
    };
    assert!(scheduled.is_null());
    let log = support::messages("fmi3_refused").join("\n");
    assert!(
        log.contains("fmi3InstantiateCoSimulation: eventModeUsed is true"),
        "{log}"
    );
    assert!(log.contains("{not-the-token}") && log.contains(GUID), "{log}");
    assert!(log.contains("fmi3InstantiateScheduledExecution: "), "{log}");
    // FMI 3.0 allows an importer without a logger: the instance is made and stays silent.
    let silent = unsafe {
        fmu.fmi3InstantiateModelExchange(
            name.as_ptr(),
            token.as_ptr(),
            null(),
            false,
            true,
            null_mut(),
            None,
        )
    };
    assert!(!silent.is_null());
    assert_eq!(
        unsafe {
            fmu.fmi3DoStep(
                silent,
                0.0,
                1.0,
                false,
                null_mut(),
                null_mut(),
                null_mut(),
                null_mut(),
            )
        },
        ERROR
    );
    unsafe { fmu.fmi3FreeInstance(silent) };
}

#[test]
fn fmu_states_round_trip_through_bytes_in_both_interfaces() {
    let fmu = load();
    for kind in [Kind::CoSimulation, Kind::ModelExchange] {
        let reals = [(vr::MU_Y, 0.05)];
        let mut tire = Instance3::initialised(&fmu, &format!("fmi3_state_{kind:?}"), kind, [2, 3], &reals);
        if kind == Kind::ModelExchange {
            tire.update_discrete_states();
            assert_eq!(unsafe { fmu.fmi3EnterContinuousTimeMode(tire.c) }, OK);
        }
        let advance = |tire: &mut Instance3, k: usize| {
            assert_eq!(tire.set_float64(&INPUTS, &inputs_at(k)), OK);
            match kind {
                Kind::CoSimulation => assert_eq!(tire.step(0.01), OK),
                Kind::ModelExchange => {
                    let (dx, _) = tire.evaluate();
                    let mut x = [0.0; 18];
                    unsafe {
                        assert_eq!(fmu.fmi3GetContinuousStates(tire.c, x.as_mut_ptr(), 18), OK);
                        x.iter_mut().zip(&dx).for_each(|(s, r)| *s += 1e-3 * r);
                        assert_eq!(fmu.fmi3SetContinuousStates(tire.c, x.as_ptr(), 18), OK);
                    }
                }
            }
        };
        (0..50).for_each(|k| advance(&mut tire, k));
        let mut state: fmi3FMUState = null_mut();
        let mut size = 0;
        unsafe {
            assert_eq!(fmu.fmi3GetFMUState(tire.c, &mut state), OK);
            assert_eq!(fmu.fmi3SerializedFMUStateSize(tire.c, state, &mut size), OK);
        }
        let mut bytes = vec![0u8; size];
        unsafe {
            assert_eq!(
                fmu.fmi3SerializeFMUState(tire.c, state, bytes.as_mut_ptr(), size),
                OK
            )
        };
        let time = tire.time;
        let run = |tire: &mut Instance3| -> Vec<u64> {
            (50..100)
                .flat_map(|k| {
                    advance(tire, k);
                    tire.get_float64(&vr::OUTPUTS)
                        .into_iter()
                        .map(f64::to_bits)
                        .collect::<Vec<_>>()
                })
                .collect()
        };
        let first = run(&mut tire);
        let mut fresh = Instance3::instantiate(&fmu, &format!("fmi3_restored_{kind:?}"), kind);
        let mut restored: fmi3FMUState = null_mut();
        unsafe {
            assert_eq!(
                fmu.fmi3DeserializeFMUState(fresh.c, bytes.as_ptr(), size, &mut restored),
                OK
            );
            assert_eq!(fmu.fmi3SetFMUState(fresh.c, restored), OK, "{}", fresh.log());
            assert_eq!(fmu.fmi3FreeFMUState(fresh.c, &mut restored), OK);
            assert_eq!(fmu.fmi3FreeFMUState(tire.c, &mut state), OK);
        }
        assert!(
            restored.is_null() && state.is_null(),
            "a freed state's slot is cleared"
        );
        fresh.time = time;
        assert_eq!(
            run(&mut fresh),
            first,
            "{kind:?}: the restored instance continues bit for bit"
        );
    }
}

#[test]
fn logging_goes_through_the_fmi3_callback_as_plain_text() {
    let fmu = load();
    let tire = Instance3::instantiate(&fmu, "fmi3_logging", Kind::CoSimulation);
    let categories = [c"logAll".as_ptr()];
    assert_eq!(
        unsafe { fmu.fmi3SetDebugLogging(tire.c, true, 1, categories.as_ptr()) },
        OK
    );
    assert_eq!(tire.set_float64(&[vr::MU_Y], &[0.5]), OK);
    assert_eq!(tire.set_float64(&[999], &[1.0]), ERROR);
    let log = tire.log();
    assert!(
        log.contains("|0|fmi3SetDebugLogging(loggingOn = true, categories = [logAll])"),
        "{log}"
    );
    assert!(
        log.contains("|0|fmi3SetFloat64(vr = [123], value = [0.5])"),
        "{log}"
    );
    assert!(
        log.contains("|3|fmi3SetFloat64: unknown value reference 999"),
        "{log}"
    );
    let reset = unsafe { fmu.fmi3Reset(tire.c) };
    assert_eq!(reset, OK);
    // FMI 3.0 does not format the message: a '%' arrives once.
    let percent = CString::new("100%").unwrap();
    let status = unsafe { fmu.fmi3SetString(tire.c, [130].as_ptr(), 1, [percent.as_ptr()].as_ptr(), 1) };
    assert_eq!(status, OK);
    assert_eq!(
        unsafe { fmu.fmi3EnterInitializationMode(tire.c, false, 0.0, 0.0, false, 0.0) },
        OK
    );
    assert_eq!(
        unsafe { fmu.fmi3ExitInitializationMode(tire.c) },
        ERROR,
        "no such file"
    );
    let log = tire.log();
    assert!(log.contains("'100%'") && !log.contains("100%%"), "{log}");
}
