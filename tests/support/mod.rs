//! An importer for the tests: loads the packed FMU binary with libloading (through the
//! bindgen loader of the official headers) and drives it through the C ABI. [`fmi_crate`]
//! holds what the tests through the `fmi` crate, a second importer, share.

#![allow(dead_code)]

use std::ffi::{CString, c_void};
use std::path::PathBuf;
use std::ptr::null_mut;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, Once};

use fmi_sys::fmi2::*;

pub mod fmi3;
pub mod fmi_crate;

pub const OK: fmi2Status = fmi2Status_fmi2OK;
pub const ERROR: fmi2Status = fmi2Status_fmi2Error;

pub const GUID: &str = tirelag::fmi::variables::GUID;

pub mod vr {
    pub const VX: u32 = 1;
    pub const VY: u32 = 2;
    pub const STEER_RATE: u32 = 3;
    pub const VSX: u32 = 4;
    pub const FZ: u32 = 5;
    pub const FX: u32 = 11;
    pub const FY: u32 = 12;
    pub const MZ: u32 = 13;
    pub const MY: u32 = 14;
    pub const OUTPUTS: [u32; 9] = [11, 12, 13, 14, 15, 16, 17, 18, 19];
    pub const MODEL: u32 = 100;
    pub const FRICTION: u32 = 121;
    pub const MU_X: u32 = 122;
    pub const MU_Y: u32 = 123;
    pub const CALPHA: u32 = 101;
    pub const CKAPPA: u32 = 102;
    pub const SIGMA_Y: u32 = 103;
    pub const SIGMA_X: u32 = 104;
    pub const SIGMA_TREAD: u32 = 119;
}

/// The shared yardstick's inputs `[vx, vy, steerRate, vsx, Fz]` at each of `steps` steps
/// of `step` seconds: vy = 0.1 sin t, steerRate = 0.05 cos t, vsx = 0.01 sin t; "varying",
/// vx = 10 + 0.001 (k mod 1000) and Fz = 50000 (1 + 0.02 sin 2t) changing every step as in
/// a vehicle model, else vx = 10 and Fz = 50000 (the benchmarks tabulate them).
pub fn yardstick_inputs(varying: bool, steps: usize, step: f64) -> Vec<[f64; 5]> {
    (0..steps)
        .map(|k| {
            let t = k as f64 * step;
            let (vx, fz) = if varying {
                (
                    10.0 + 1e-3 * (k % 1000) as f64,
                    50_000.0 * (1.0 + 0.02 * (2.0 * t).sin()),
                )
            } else {
                (10.0, 50_000.0)
            };
            [vx, 0.1 * t.sin(), 0.05 * t.cos(), 0.01 * t.sin(), fz]
        })
        .collect()
}

/// (steps per pass, timed passes) of a benchmark: `cargo test --benches` runs it without
/// --bench, and then a short smoke pass is enough.
pub fn bench_size() -> (usize, usize) {
    if std::env::args().any(|a| a == "--bench") {
        (20_000, 15)
    } else {
        (200, 1)
    }
}

/// The median of timings, and their smallest and largest: "median (min-max)".
pub fn timing_cell(mut times: Vec<f64>) -> (f64, String) {
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    let cell = format!("{median:.0} ({:.0}-{:.0})", times[0], times[times.len() - 1]);
    (median, cell)
}

/// A file written by `./scripts/build-fmu`: the path in `env_var`, else `relative` to the
/// crate. A missing file fails the test with the command that makes it.
pub fn packed_artifact(env_var: &str, relative: &str) -> PathBuf {
    let path = std::env::var_os(env_var)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(relative));
    assert!(
        path.is_file(),
        "{} is missing: run ./scripts/build-fmu first (or set {env_var})",
        path.display()
    );
    path
}

/// The archive entry `name` of the FMU at `relative` (or the path in `env_var`) that holds
/// one platform's binary. None, with a note, when the FMU was packed for Linux x86_64 alone
/// (`./scripts/build-fmu --native`); under `./scripts/test`, which packs every platform
/// (TIRELAG_ALL_PLATFORMS=1), a missing binary fails the test.
pub fn platform_binary(env_var: &str, relative: &str, name: &str) -> Option<Vec<u8>> {
    use std::io::Read;
    let fmu = packed_artifact(env_var, relative);
    let mut archive =
        zip::ZipArchive::new(std::fs::File::open(&fmu).unwrap()).expect("the FMU is a zip archive");
    let Ok(mut entry) = archive.by_name(name) else {
        let all = std::env::var("TIRELAG_ALL_PLATFORMS").as_deref() == Ok("1");
        assert!(
            !all,
            "{} holds no {name}: ./scripts/build-fmu packs every platform",
            fmu.display()
        );
        println!(
            "skipped: {} holds no {name} (packed with --native)",
            fmu.display()
        );
        return None;
    };
    let mut bytes = Vec::new();
    entry.read_to_end(&mut bytes).unwrap();
    Some(bytes)
}

/// The packed binary, also unpacked as `target/fmu/TireLag.so`.
pub fn binary_path() -> PathBuf {
    packed_artifact("TIRELAG_SO", "target/fmu/TireLag.so")
}

pub fn load() -> Fmi2Binding {
    // SAFETY: the FMU binary has no library constructors with preconditions.
    unsafe { Fmi2Binding::new(binary_path()) }
        .expect("the FMU binary loads and exports every FMI 2.0 function")
}

/// Messages the FMU sent to the logger, as "instance|level|message".
static MESSAGES: Mutex<Vec<String>> = Mutex::new(Vec::new());
/// Whether messages are kept (long fuzz runs only count them).
static RECORD: AtomicBool = AtomicBool::new(true);
static COUNT: AtomicUsize = AtomicUsize::new(0);

/// Stop keeping messages; they are still formatted and counted.
pub fn stop_recording() {
    RECORD.store(false, Ordering::Relaxed);
}

pub fn message_count() -> usize {
    COUNT.load(Ordering::Relaxed)
}

/// Keeps a log line "instance|level|message" (both versions' loggers end here).
pub fn record(line: String) {
    COUNT.fetch_add(1, Ordering::Relaxed);
    if RECORD.load(Ordering::Relaxed) {
        MESSAGES.lock().unwrap().push(line);
    }
}

struct Capture;

impl log::Log for Capture {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, entry: &log::Record) {
        record(format!("{}|{}|{}", entry.target(), entry.level(), entry.args()));
    }
    fn flush(&self) {}
}

/// The log lines of one instance name (names are unique per test).
pub fn messages(instance_name: &str) -> Vec<String> {
    let prefix = format!("{instance_name}|");
    MESSAGES
        .lock()
        .unwrap()
        .iter()
        .filter(|l| l.starts_with(&prefix))
        .cloned()
        .collect()
}

/// Callbacks whose logger is fmi-sys's C variadic handler, forwarding to `log`.
pub fn callbacks() -> fmi2CallbackFunctions {
    static INIT: Once = Once::new();
    INIT.call_once(|| {
        log::set_logger(&Capture).unwrap();
        log::set_max_level(log::LevelFilter::Trace);
    });
    fmi2CallbackFunctions {
        logger: Some(fmi_sys::fmi2::logger::callback_logger_handler),
        allocateMemory: None,
        freeMemory: None,
        stepFinished: None,
        componentEnvironment: null_mut::<c_void>(),
    }
}

/// An instance with its binding; freed on drop.
pub struct Slave<'a> {
    pub fmu: &'a Fmi2Binding,
    pub c: fmi2Component,
    pub name: String,
    _callbacks: Box<fmi2CallbackFunctions>,
    pub time: f64,
}

impl<'a> Slave<'a> {
    pub fn instantiate(fmu: &'a Fmi2Binding, name: &str) -> Self {
        Self::instantiate_as(fmu, name, fmi2Type_fmi2CoSimulation)
    }

    /// An instance for Co-Simulation or Model Exchange (`kind`).
    pub fn instantiate_as(fmu: &'a Fmi2Binding, name: &str, kind: fmi2Type) -> Self {
        let callbacks = Box::new(callbacks());
        let c_name = CString::new(name).unwrap();
        let guid = CString::new(GUID).unwrap();
        let c = unsafe {
            fmu.fmi2Instantiate(
                c_name.as_ptr(),
                kind,
                guid.as_ptr(),
                c"".as_ptr(),
                &*callbacks,
                0,
                0,
            )
        };
        assert!(!c.is_null(), "instantiate failed: {:?}", messages(name));
        Slave {
            fmu,
            c,
            name: name.to_owned(),
            _callbacks: callbacks,
            time: 0.0,
        }
    }

    /// Instantiated, model chosen, initialised, ready to step.
    pub fn initialised(fmu: &'a Fmi2Binding, name: &str, model: i32) -> Self {
        Self::configured(fmu, name, &[(vr::MODEL, model)], &[])
    }

    /// Instantiated, the given Integer and Real parameters set, initialised.
    pub fn configured(
        fmu: &'a Fmi2Binding,
        name: &str,
        integers: &[(u32, i32)],
        reals: &[(u32, f64)],
    ) -> Self {
        Self::configured_as(fmu, name, fmi2Type_fmi2CoSimulation, integers, reals)
    }

    /// [`Slave::configured`] for Co-Simulation or Model Exchange (`kind`; Model Exchange
    /// is left in event mode).
    pub fn configured_as(
        fmu: &'a Fmi2Binding,
        name: &str,
        kind: fmi2Type,
        integers: &[(u32, i32)],
        reals: &[(u32, f64)],
    ) -> Self {
        let s = Self::instantiate_as(fmu, name, kind);
        assert_eq!(unsafe { fmu.fmi2SetupExperiment(s.c, 0, 0.0, 0.0, 0, 0.0) }, OK);
        for &(reference, value) in integers {
            assert_eq!(s.set_integer(&[reference], &[value]), OK);
        }
        for &(reference, value) in reals {
            assert_eq!(s.set_real(&[reference], &[value]), OK);
        }
        assert_eq!(unsafe { fmu.fmi2EnterInitializationMode(s.c) }, OK);
        assert_eq!(unsafe { fmu.fmi2ExitInitializationMode(s.c) }, OK);
        s
    }

    pub fn set_real(&self, refs: &[u32], values: &[f64]) -> fmi2Status {
        unsafe {
            self.fmu
                .fmi2SetReal(self.c, refs.as_ptr(), refs.len(), values.as_ptr())
        }
    }

    pub fn set_integer(&self, refs: &[u32], values: &[i32]) -> fmi2Status {
        unsafe {
            self.fmu
                .fmi2SetInteger(self.c, refs.as_ptr(), refs.len(), values.as_ptr())
        }
    }

    pub fn get_real(&self, refs: &[u32]) -> Vec<f64> {
        let mut values = vec![f64::NAN; refs.len()];
        let status = unsafe {
            self.fmu
                .fmi2GetReal(self.c, refs.as_ptr(), refs.len(), values.as_mut_ptr())
        };
        assert_eq!(status, OK, "{:?}", messages(&self.name));
        values
    }

    pub fn step(&mut self, h: f64) -> fmi2Status {
        let status = unsafe { self.fmu.fmi2DoStep(self.c, self.time, h, 1) };
        if status == OK {
            self.time += h;
        }
        status
    }

    pub fn outputs(&self) -> Vec<f64> {
        self.get_real(&vr::OUTPUTS)
    }
}

impl Drop for Slave<'_> {
    fn drop(&mut self) {
        unsafe { self.fmu.fmi2FreeInstance(self.c) };
    }
}
