//! The packed FMU binary driven through its C ABI, as an importer would.

mod support;

use std::ffi::CString;
use std::ptr::null_mut;

use fmi_sys::fmi2::*;
use support::{ERROR, GUID, OK, Slave, load, messages, vr};

#[test]
fn every_fmi2_function_is_exported() {
    let fmu = load();
    let present = [
        fmu.fmi2GetTypesPlatform.is_ok(),
        fmu.fmi2GetVersion.is_ok(),
        fmu.fmi2SetDebugLogging.is_ok(),
        fmu.fmi2Instantiate.is_ok(),
        fmu.fmi2FreeInstance.is_ok(),
        fmu.fmi2SetupExperiment.is_ok(),
        fmu.fmi2EnterInitializationMode.is_ok(),
        fmu.fmi2ExitInitializationMode.is_ok(),
        fmu.fmi2Terminate.is_ok(),
        fmu.fmi2Reset.is_ok(),
        fmu.fmi2GetReal.is_ok(),
        fmu.fmi2GetInteger.is_ok(),
        fmu.fmi2GetBoolean.is_ok(),
        fmu.fmi2GetString.is_ok(),
        fmu.fmi2SetReal.is_ok(),
        fmu.fmi2SetInteger.is_ok(),
        fmu.fmi2SetBoolean.is_ok(),
        fmu.fmi2SetString.is_ok(),
        fmu.fmi2GetFMUstate.is_ok(),
        fmu.fmi2SetFMUstate.is_ok(),
        fmu.fmi2FreeFMUstate.is_ok(),
        fmu.fmi2SerializedFMUstateSize.is_ok(),
        fmu.fmi2SerializeFMUstate.is_ok(),
        fmu.fmi2DeSerializeFMUstate.is_ok(),
        fmu.fmi2GetDirectionalDerivative.is_ok(),
        fmu.fmi2SetRealInputDerivatives.is_ok(),
        fmu.fmi2GetRealOutputDerivatives.is_ok(),
        fmu.fmi2DoStep.is_ok(),
        fmu.fmi2CancelStep.is_ok(),
        fmu.fmi2GetStatus.is_ok(),
        fmu.fmi2GetRealStatus.is_ok(),
        fmu.fmi2GetIntegerStatus.is_ok(),
        fmu.fmi2GetBooleanStatus.is_ok(),
        fmu.fmi2GetStringStatus.is_ok(),
    ];
    assert!(present.iter().all(|&p| p), "{present:?}");
    let version = unsafe { std::ffi::CStr::from_ptr(fmu.fmi2GetVersion()) };
    assert_eq!(version.to_str().unwrap(), "2.0");
}

#[test]
fn full_cycle_rlt_matches_the_closed_form_lag() {
    let fmu = load();
    let mut s = Slave::initialised(&fmu, "full_cycle", 1);
    let (vx, vy, vsx) = (5.0, -0.1, 0.02);
    assert_eq!(s.set_real(&[vr::VX, vr::VY, vr::VSX], &[vx, vy, vsx]), OK);
    for _ in 0..30 {
        assert_eq!(s.step(0.01), OK);
    }
    let t = s.time;
    // uY(t) = sigmaY vy / rho (1 - exp(-rho t / sigmaY)), Fy = -(Calpha/sigmaY) uY.
    let (calpha, sigma_y) = (350_000.0, 1.0);
    let expected_fy = -calpha * vy / vx * (1.0 - (-vx * t / sigma_y).exp());
    let (ckappa, sigma_x) = (500_000.0, 0.5);
    let expected_fx = -ckappa * vsx / vx * (1.0 - (-vx * t / sigma_x).exp());
    let y = s.get_real(&[vr::FX, vr::FY, vr::MZ, vr::MY]);
    assert!(
        (y[1] - expected_fy).abs() <= 1e-9 * expected_fy.abs(),
        "{} vs {expected_fy}",
        y[1]
    );
    assert!(
        (y[0] - expected_fx).abs() <= 1e-9 * expected_fx.abs(),
        "{} vs {expected_fx}",
        y[0]
    );
    assert!((y[2] + 0.05 * y[1]).abs() <= 1e-9 * y[1].abs(), "Mz = -trail Fy");
    assert!((y[3] + 0.6 * y[0]).abs() <= 1e-9 * y[0].abs(), "My = -Re Fx");
    assert_eq!(unsafe { fmu.fmi2Terminate(s.c) }, OK);
}

#[test]
fn every_model_initialises_and_steps() {
    let fmu = load();
    for model in 1..=4 {
        let mut s = Slave::initialised(&fmu, &format!("model_{model}"), model);
        assert_eq!(
            s.set_real(&[vr::VX, vr::VY, vr::STEER_RATE, vr::VSX], &[0.0, 0.1, 0.2, 0.05]),
            OK
        );
        assert_eq!(s.step(0.1), OK);
        assert!(s.outputs().iter().all(|v| v.is_finite()));
        assert!(
            s.outputs()[1] != 0.0,
            "model {model} makes a lateral force at standstill"
        );
    }
}

#[test]
fn illegal_call_sequences_return_error_and_say_why() {
    let fmu = load();
    let mut s = Slave::instantiate(&fmu, "illegal_sequence");
    assert_eq!(s.step(0.1), ERROR, "fmi2DoStep before initialisation");
    assert_eq!(unsafe { fmu.fmi2ExitInitializationMode(s.c) }, ERROR);
    let log = messages("illegal_sequence").join("\n");
    assert!(
        log.contains("fmi2DoStep: this call is not allowed in instantiated; it is allowed in step mode"),
        "{log}"
    );
    assert!(log.contains("fmi2ExitInitializationMode"), "{log}");
    // The instance is still usable.
    assert_eq!(unsafe { fmu.fmi2EnterInitializationMode(s.c) }, OK);
    assert_eq!(unsafe { fmu.fmi2ExitInitializationMode(s.c) }, OK);
    assert_eq!(s.step(0.1), OK);
    assert_eq!(unsafe { fmu.fmi2CancelStep(s.c) }, ERROR);
    assert_eq!(
        unsafe { fmu.fmi2DoStep(s.c, s.time + 1.0, 0.1, 1) },
        ERROR,
        "wrong communication point"
    );
    assert_eq!(unsafe { fmu.fmi2DoStep(s.c, s.time, 0.0, 1) }, ERROR, "zero step");
    assert_eq!(
        unsafe { fmu.fmi2DoStep(s.c, s.time, -1.0, 1) },
        ERROR,
        "negative step"
    );
    assert_eq!(unsafe { fmu.fmi2Terminate(s.c) }, OK);
    assert_eq!(s.step(0.1), ERROR, "fmi2DoStep after fmi2Terminate");
    assert_eq!(unsafe { fmu.fmi2Reset(s.c) }, OK);
    assert_eq!(unsafe { fmu.fmi2EnterInitializationMode(s.c) }, OK);
}

#[test]
fn a_step_past_stop_time_is_an_error() {
    let fmu = load();
    let mut s = Slave::instantiate(&fmu, "stop_time");
    assert_eq!(unsafe { fmu.fmi2SetupExperiment(s.c, 0, 0.0, 0.0, 1, 1.0) }, OK);
    assert_eq!(unsafe { fmu.fmi2EnterInitializationMode(s.c) }, OK);
    assert_eq!(unsafe { fmu.fmi2ExitInitializationMode(s.c) }, OK);
    for _ in 0..10 {
        assert_eq!(s.step(0.1), OK, "steps up to the stop time, within rounding");
    }
    assert_eq!(s.step(0.1), ERROR);
    assert!(messages("stop_time").join("\n").contains("past stopTime 1 s"));
}

fn instantiate_raw(
    fmu: &Fmi2Binding,
    name: &str,
    kind: fmi2Type,
    guid: &str,
    callbacks: *const fmi2CallbackFunctions,
) -> fmi2Component {
    let name = CString::new(name).unwrap();
    let guid = CString::new(guid).unwrap();
    unsafe { fmu.fmi2Instantiate(name.as_ptr(), kind, guid.as_ptr(), c"".as_ptr(), callbacks, 0, 0) }
}

#[test]
fn instantiate_refuses_bad_requests_with_a_logged_reason() {
    let fmu = load();
    let callbacks = support::callbacks();
    let c = instantiate_raw(
        &fmu,
        "wrong_guid",
        fmi2Type_fmi2CoSimulation,
        "{not-the-guid}",
        &callbacks,
    );
    assert!(c.is_null());
    let log = messages("wrong_guid").join("\n");
    assert!(log.contains("{not-the-guid}") && log.contains(GUID), "{log}");

    let c = instantiate_raw(&fmu, "unknown_type", 7, GUID, &callbacks);
    assert!(c.is_null());
    assert!(
        messages("unknown_type")
            .join("\n")
            .contains("fmuType 7 is neither fmi2ModelExchange (0) nor fmi2CoSimulation (1)")
    );

    let c = instantiate_raw(&fmu, "", fmi2Type_fmi2CoSimulation, GUID, &callbacks);
    assert!(c.is_null());
    assert!(
        messages("")
            .join("\n")
            .contains("instanceName must be a non-empty string")
    );

    let c = instantiate_raw(
        &fmu,
        "no_callbacks",
        fmi2Type_fmi2CoSimulation,
        GUID,
        std::ptr::null(),
    );
    assert!(c.is_null());
    let no_logger = fmi2CallbackFunctions {
        logger: None,
        ..callbacks
    };
    assert!(instantiate_raw(&fmu, "no_logger", fmi2Type_fmi2CoSimulation, GUID, &no_logger).is_null());
    let c = unsafe {
        fmu.fmi2Instantiate(
            std::ptr::null(),
            fmi2Type_fmi2CoSimulation,
            std::ptr::null(),
            std::ptr::null(),
            &callbacks,
            0,
            0,
        )
    };
    assert!(c.is_null());
}

#[test]
fn bad_values_are_refused_by_name_and_nothing_changes() {
    let fmu = load();
    let s = Slave::instantiate(&fmu, "bad_values");
    assert_eq!(s.set_real(&[vr::SIGMA_Y], &[-1.0]), ERROR);
    assert_eq!(s.set_real(&[vr::CALPHA, vr::SIGMA_Y], &[123.0, f64::NAN]), ERROR);
    assert_eq!(s.set_real(&[9999], &[1.0]), ERROR);
    assert_eq!(s.set_integer(&[vr::MODEL], &[7]), ERROR);
    assert_eq!(s.set_real(&[vr::FY], &[1.0]), ERROR, "outputs cannot be set");
    let log = messages("bad_values").join("\n");
    assert!(
        log.contains("sigmaY = -1 m is out of range: must be finite and > 0"),
        "{log}"
    );
    assert!(
        log.contains("cannot set sigmaY = NaN: the value is not finite"),
        "{log}"
    );
    assert!(log.contains("unknown value reference 9999"), "{log}");
    assert!(log.contains("cannot set tireModel = 7"), "{log}");
    unsafe {
        assert_eq!(fmu.fmi2EnterInitializationMode(s.c), OK);
        assert_eq!(fmu.fmi2ExitInitializationMode(s.c), OK);
    }
    assert_eq!(
        s.get_real(&[vr::CALPHA, vr::SIGMA_Y]),
        vec![350_000.0, 1.0],
        "a refused call sets nothing"
    );
    assert_eq!(
        s.set_real(&[vr::CALPHA], &[1.0]),
        ERROR,
        "fixed parameter after initialisation"
    );
    assert!(messages("bad_values").join("\n").contains("fixed parameter"));
    assert_eq!(s.set_real(&[vr::VY], &[f64::INFINITY]), ERROR);
    assert_eq!(s.get_real(&[vr::VY]), vec![0.0]);
}

#[test]
fn inconsistent_parameters_fail_at_initialisation_naming_them() {
    let fmu = load();
    let s = Slave::instantiate(&fmu, "inconsistent");
    assert_eq!(s.set_integer(&[vr::MODEL], &[3]), OK);
    assert_eq!(
        s.set_real(&[vr::SIGMA_Y], &[0.05]),
        OK,
        "each value is fine on its own"
    );
    unsafe {
        assert_eq!(fmu.fmi2EnterInitializationMode(s.c), OK);
        assert_eq!(fmu.fmi2ExitInitializationMode(s.c), ERROR);
    }
    let log = messages("inconsistent").join("\n");
    assert!(
        log.contains(
            "sigmaTread = 0.1 m is out of range: must be below sigmaY = 0.05 m for the SecondOrder model"
        ),
        "{log}"
    );
    // Fix it and carry on.
    assert_eq!(s.set_real(&[vr::SIGMA_Y], &[1.0]), OK);
    assert_eq!(unsafe { fmu.fmi2ExitInitializationMode(s.c) }, OK);
}

#[test]
fn lifted_off_wheel_is_not_an_error() {
    let fmu = load();
    let mut s = Slave::initialised(&fmu, "lift_off", 2);
    assert_eq!(s.set_real(&[vr::VX, vr::VY, vr::FZ], &[3.0, 0.3, -100.0]), OK);
    assert_eq!(s.step(0.1), OK);
    let y = s.get_real(&[vr::FX, vr::FY, vr::MZ, vr::MY]);
    assert_eq!(y, vec![0.0; 4]);
}

#[test]
fn null_pointers_are_refused_not_followed() {
    let fmu = load();
    let s = Slave::initialised(&fmu, "null_pointers", 2);
    unsafe {
        assert_eq!(fmu.fmi2GetReal(s.c, std::ptr::null(), 2, null_mut()), ERROR);
        assert_eq!(fmu.fmi2SetReal(s.c, [1u32].as_ptr(), 1, std::ptr::null()), ERROR);
        assert_eq!(
            fmu.fmi2GetReal(null_mut(), std::ptr::null(), 0, null_mut()),
            ERROR
        );
        assert_eq!(
            fmu.fmi2GetReal(s.c, std::ptr::null(), 0, null_mut()),
            OK,
            "zero values need no arrays"
        );
        assert_eq!(fmu.fmi2GetFMUstate(s.c, null_mut()), ERROR);
        assert_eq!(fmu.fmi2SetFMUstate(s.c, null_mut()), ERROR);
        assert_eq!(
            fmu.fmi2DeSerializeFMUstate(s.c, std::ptr::null(), 10, null_mut()),
            ERROR
        );
        fmu.fmi2FreeInstance(null_mut());
    }
}

/// Runs a deterministic scenario on a fresh instance and returns every output of every step.
fn scenario(fmu: &Fmi2Binding, name: &str, model: i32, steps: usize) -> Vec<f64> {
    let mut s = Slave::initialised(fmu, name, model);
    let mut trace = Vec::with_capacity(steps * 9);
    for k in 0..steps {
        let t = k as f64 * 0.01;
        let vx = 10.0 * (0.3 * t).cos();
        assert_eq!(
            s.set_real(
                &[vr::VX, vr::VY, vr::STEER_RATE, vr::VSX],
                &[vx, 0.2 * t.sin(), 0.1, 0.01]
            ),
            OK
        );
        assert_eq!(s.step(0.01), OK);
        trace.extend(s.outputs());
    }
    trace
}

#[test]
fn eight_threads_give_the_same_bits_as_one_after_another() {
    let fmu = load();
    let sequential: Vec<Vec<f64>> = (0..8)
        .map(|i| scenario(&fmu, &format!("seq_{i}"), 1 + i % 4, 500))
        .collect();
    let concurrent: Vec<Vec<f64>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..8)
            .map(|i| {
                scope.spawn({
                    let fmu = &fmu;
                    move || scenario(fmu, &format!("thread_{i}"), 1 + i % 4, 500)
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for (a, b) in sequential.iter().zip(&concurrent) {
        assert!(a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()));
    }
}

#[test]
fn a_thousand_load_instantiate_free_unload_cycles_run_clean() {
    let cycles: usize = std::env::var("TIRELAG_LOAD_CYCLES").map_or(1000, |v| v.parse().unwrap());
    for i in 0..cycles {
        let fmu = load();
        let mut s = Slave::initialised(&fmu, "cycle", 1 + (i % 4) as i32);
        assert_eq!(s.step(0.01), OK);
        drop(s);
        drop(fmu); // dlclose
    }
}

#[test]
fn fmu_state_round_trips_through_bytes_and_continues_bit_identically() {
    let fmu = load();
    for model in 1..=4 {
        let mut s = Slave::initialised(&fmu, &format!("state_{model}"), model);
        assert_eq!(
            s.set_real(&[vr::VX, vr::VY, vr::STEER_RATE, vr::VSX], &[3.0, 0.2, 0.1, 0.05]),
            OK
        );
        for _ in 0..10 {
            assert_eq!(s.step(0.01), OK);
        }
        let mut state: fmi2FMUstate = null_mut();
        let mut size = 0usize;
        let bytes = unsafe {
            assert_eq!(fmu.fmi2GetFMUstate(s.c, &mut state), OK);
            assert_eq!(fmu.fmi2SerializedFMUstateSize(s.c, state, &mut size), OK);
            let mut bytes = vec![0u8; size];
            assert_eq!(
                fmu.fmi2SerializeFMUstate(s.c, state, bytes.as_mut_ptr().cast(), size),
                OK
            );
            assert_eq!(fmu.fmi2FreeFMUstate(s.c, &mut state), OK);
            assert!(state.is_null());
            bytes
        };
        let saved_time = s.time;
        let mut first = Vec::new();
        for _ in 0..100 {
            assert_eq!(s.step(0.01), OK);
            first.extend(s.outputs());
        }
        // A corrupt copy is refused and changes nothing.
        let mut corrupt = bytes.clone();
        corrupt[size / 2] ^= 0x40;
        let mut restored: fmi2FMUstate = null_mut();
        unsafe {
            assert_eq!(
                fmu.fmi2DeSerializeFMUstate(s.c, corrupt.as_ptr().cast(), size, &mut restored),
                ERROR
            );
            assert_eq!(
                fmu.fmi2DeSerializeFMUstate(s.c, bytes.as_ptr().cast(), size - 1, &mut restored),
                ERROR
            );
            assert!(restored.is_null());
            assert_eq!(
                fmu.fmi2DeSerializeFMUstate(s.c, bytes.as_ptr().cast(), size, &mut restored),
                OK
            );
            assert_eq!(fmu.fmi2SetFMUstate(s.c, restored), OK);
            assert_eq!(fmu.fmi2FreeFMUstate(s.c, &mut restored), OK);
        }
        s.time = saved_time;
        let mut second = Vec::new();
        for _ in 0..100 {
            assert_eq!(s.step(0.01), OK);
            second.extend(s.outputs());
        }
        assert!(
            first.iter().zip(&second).all(|(a, b)| a.to_bits() == b.to_bits()),
            "model {model}"
        );
    }
}

#[test]
fn reset_restores_start_values_and_time() {
    let fmu = load();
    let mut s = Slave::initialised(&fmu, "reset", 3);
    assert_eq!(s.set_real(&[vr::VX, vr::VY], &[2.0, 0.5]), OK);
    assert_eq!(s.step(0.5), OK);
    assert_eq!(unsafe { fmu.fmi2Reset(s.c) }, OK);
    assert_eq!(
        s.set_real(&[vr::CALPHA], &[1000.0]),
        OK,
        "parameters are settable again"
    );
    assert_eq!(unsafe { fmu.fmi2Reset(s.c) }, OK);
    unsafe {
        assert_eq!(fmu.fmi2EnterInitializationMode(s.c), OK);
        assert_eq!(fmu.fmi2ExitInitializationMode(s.c), OK);
    }
    let mut model = [0];
    assert_eq!(
        unsafe { fmu.fmi2GetInteger(s.c, [vr::MODEL].as_ptr(), 1, model.as_mut_ptr()) },
        OK
    );
    assert_eq!(model, [2], "model back to its start value DDT");
    assert_eq!(
        s.get_real(&[vr::VX, vr::VY, vr::FZ, vr::CALPHA]),
        vec![0.0, 0.0, 50_000.0, 350_000.0]
    );
    assert_eq!(s.outputs(), vec![0.0; 9], "states back to rest");
    s.time = 0.0;
    assert_eq!(s.step(0.1), OK, "time starts again at 0");
}

#[test]
fn output_derivatives_and_status_functions() {
    let fmu = load();
    let mut s = Slave::initialised(&fmu, "derivatives", 1);
    assert_eq!(s.set_real(&[vr::VX, vr::VY], &[5.0, -0.1]), OK);
    assert_eq!(s.step(0.1), OK);
    let mut rates = [0.0; 2];
    let orders = [1, 1];
    let refs = [vr::FY, 18];
    assert_eq!(
        unsafe {
            fmu.fmi2GetRealOutputDerivatives(s.c, refs.as_ptr(), 2, orders.as_ptr(), rates.as_mut_ptr())
        },
        OK
    );
    // RLT: d deflY/dt = vy - (rho/sigmaY) deflY and dFy/dt = -(Calpha/sigmaY) d deflY/dt.
    let defl_y = s.get_real(&[18])[0];
    let expected = -0.1 - 5.0 * defl_y;
    assert!((rates[1] - expected).abs() <= 1e-12 * expected.abs());
    assert!((rates[0] + 350_000.0 * expected).abs() <= 1e-9 * (350_000.0 * expected).abs());
    let second_order = [2, 2];
    assert_eq!(
        unsafe {
            fmu.fmi2GetRealOutputDerivatives(s.c, refs.as_ptr(), 2, second_order.as_ptr(), rates.as_mut_ptr())
        },
        ERROR
    );
    let mut time = 0.0;
    let mut flag = 1;
    let mut status = ERROR;
    unsafe {
        assert_eq!(
            fmu.fmi2GetRealStatus(s.c, fmi2StatusKind_fmi2LastSuccessfulTime, &mut time),
            OK
        );
        assert_eq!(
            fmu.fmi2GetBooleanStatus(s.c, fmi2StatusKind_fmi2Terminated, &mut flag),
            OK
        );
        assert_eq!(
            fmu.fmi2GetStatus(s.c, fmi2StatusKind_fmi2DoStepStatus, &mut status),
            OK
        );
        assert_eq!(
            fmu.fmi2GetStatus(s.c, fmi2StatusKind_fmi2PendingStatus, &mut status),
            fmi2Status_fmi2Discard
        );
    }
    assert_eq!((time, flag, status), (0.1, 0, OK));
}
