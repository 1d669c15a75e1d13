//! The FMI 3.0 side of the test importer: the packed binary loaded through the bindgen
//! loader of the official FMI 3.0 headers, and instances whose log lines land with the
//! FMI 2.0 ones (as "instance|status|message", see [`super::messages`]).

use std::ffi::{CStr, CString, c_char, c_void};
use std::ptr::{null, null_mut};

use fmi_sys::fmi3::*;

pub const OK: fmi3Status = fmi3Status_fmi3OK;
pub const ERROR: fmi3Status = fmi3Status_fmi3Error;

pub fn load() -> Fmi3Binding {
    // SAFETY: the FMU binary has no library constructors with preconditions.
    unsafe { Fmi3Binding::new(super::binary_path()) }
        .expect("the FMU binary loads and exports every FMI 3.0 function")
}

/// The FMI 3.0 logger: the instance environment is the instance's name (a C string).
pub unsafe extern "C" fn log_message(
    environment: fmi3InstanceEnvironment,
    status: fmi3Status,
    _category: fmi3String,
    message: fmi3String,
) {
    let name = unsafe { CStr::from_ptr(environment.cast::<c_char>()) }.to_string_lossy();
    let message = unsafe { CStr::from_ptr(message) }.to_string_lossy();
    super::record(format!("{name}|{status}|{message}"));
}

/// Co-Simulation or Model Exchange.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    CoSimulation,
    ModelExchange,
}

/// An FMI 3.0 instance with its binding; freed on drop.
pub struct Instance3<'a> {
    pub fmu: &'a Fmi3Binding,
    pub c: fmi3Instance,
    pub name: CString,
    pub time: f64,
}

impl<'a> Instance3<'a> {
    pub fn instantiate(fmu: &'a Fmi3Binding, name: &str, kind: Kind) -> Self {
        let name = CString::new(name).unwrap();
        let token = CString::new(super::GUID).unwrap();
        let environment = name.as_ptr().cast_mut().cast::<c_void>();
        let c = unsafe {
            match kind {
                Kind::CoSimulation => fmu.fmi3InstantiateCoSimulation(
                    name.as_ptr(),
                    token.as_ptr(),
                    null(),
                    false,
                    false,
                    false,
                    false,
                    null(),
                    0,
                    environment,
                    Some(log_message),
                    None,
                ),
                Kind::ModelExchange => fmu.fmi3InstantiateModelExchange(
                    name.as_ptr(),
                    token.as_ptr(),
                    null(),
                    false,
                    false,
                    environment,
                    Some(log_message),
                ),
            }
        };
        assert!(
            !c.is_null(),
            "instantiate failed: {:?}",
            super::messages(name.to_str().unwrap())
        );
        Instance3 {
            fmu,
            c,
            name,
            time: 0.0,
        }
    }

    /// Instantiated, model and friction law chosen, the Float64 parameters set,
    /// initialised (Model Exchange: left in event mode).
    pub fn initialised(
        fmu: &'a Fmi3Binding,
        name: &str,
        kind: Kind,
        selectors: [i64; 2],
        reals: &[(u32, f64)],
    ) -> Self {
        let s = Self::instantiate(fmu, name, kind);
        assert_eq!(
            s.set_int64(&[super::vr::MODEL, super::vr::FRICTION], &selectors),
            OK
        );
        for &(reference, value) in reals {
            assert_eq!(s.set_float64(&[reference], &[value]), OK);
        }
        assert_eq!(
            unsafe { fmu.fmi3EnterInitializationMode(s.c, false, 0.0, 0.0, false, 0.0) },
            OK
        );
        assert_eq!(unsafe { fmu.fmi3ExitInitializationMode(s.c) }, OK);
        s
    }

    pub fn log(&self) -> String {
        super::messages(self.name.to_str().unwrap()).join("\n")
    }

    pub fn set_float64(&self, refs: &[u32], values: &[f64]) -> fmi3Status {
        unsafe {
            self.fmu
                .fmi3SetFloat64(self.c, refs.as_ptr(), refs.len(), values.as_ptr(), values.len())
        }
    }

    pub fn set_int64(&self, refs: &[u32], values: &[i64]) -> fmi3Status {
        unsafe {
            self.fmu
                .fmi3SetInt64(self.c, refs.as_ptr(), refs.len(), values.as_ptr(), values.len())
        }
    }

    pub fn get_float64(&self, refs: &[u32]) -> Vec<f64> {
        let mut values = vec![f64::NAN; refs.len()];
        let status = unsafe {
            self.fmu.fmi3GetFloat64(
                self.c,
                refs.as_ptr(),
                refs.len(),
                values.as_mut_ptr(),
                values.len(),
            )
        };
        assert_eq!(status, OK, "{}", self.log());
        values
    }

    pub fn step(&mut self, h: f64) -> fmi3Status {
        let (mut event, mut terminate, mut early, mut last) = (true, true, true, f64::NAN);
        let status = unsafe {
            self.fmu.fmi3DoStep(
                self.c,
                self.time,
                h,
                true,
                &mut event,
                &mut terminate,
                &mut early,
                &mut last,
            )
        };
        assert!(!event && !terminate && !early, "a step asks for nothing");
        if status == OK {
            self.time += h;
        }
        assert_eq!(last, self.time, "lastSuccessfulTime is the time reached");
        status
    }

    /// Model Exchange: derivatives and event indicators at the current point.
    pub fn evaluate(&self) -> (Vec<f64>, Vec<f64>) {
        let (mut nx, mut nz) = (0, 0);
        unsafe {
            assert_eq!(self.fmu.fmi3GetNumberOfContinuousStates(self.c, &mut nx), OK);
            assert_eq!(self.fmu.fmi3GetNumberOfEventIndicators(self.c, &mut nz), OK);
        }
        let (mut dx, mut z) = (vec![0.0; nx], vec![0.0; nz]);
        unsafe {
            assert_eq!(
                self.fmu
                    .fmi3GetContinuousStateDerivatives(self.c, dx.as_mut_ptr(), nx),
                OK
            );
            assert_eq!(self.fmu.fmi3GetEventIndicators(self.c, z.as_mut_ptr(), nz), OK);
        }
        (dx, z)
    }

    /// Model Exchange: the event update; whether the states changed.
    pub fn update_discrete_states(&self) -> bool {
        let (mut again, mut terminate, mut nominals, mut values, mut timed) = (true, true, true, false, true);
        let mut next = f64::NAN;
        let status = unsafe {
            self.fmu.fmi3UpdateDiscreteStates(
                self.c,
                &mut again,
                &mut terminate,
                &mut nominals,
                &mut values,
                &mut timed,
                &mut next,
            )
        };
        assert_eq!(status, OK, "{}", self.log());
        assert!(!again && !terminate && !nominals && !timed);
        values
    }
}

impl Drop for Instance3<'_> {
    fn drop(&mut self) {
        unsafe { self.fmu.fmi3FreeInstance(self.c) };
    }
}

/// A null instance handle, for the checks that every function refuses one.
pub const NO_INSTANCE: fmi3Instance = null_mut();
