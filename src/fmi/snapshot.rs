//! The FMU state: everything needed to continue a simulation, as a self-contained,
//! versioned and checksummed byte string (no pointers), so that a state serialized in
//! one process continues bit-identically in another.
//!
//! Layout (little endian): magic `TIRELAG\0`, format version u32, GUID (u32 length +
//! bytes), phase u8, model u8, friction law u8, time, start time, stop-time flag u8, stop
//! time, the parameters, inputs and input rates (f64 each), state count u32 and states
//! (f64 each), slider flag u8 and, if 1, the branch offsets from their element's state (f64, by direction and
//! branch), sliding flags (u8, by group and branch) and the lengths the eighth-order
//! pair's first two substeps of the next step may have (f64 each, positive, infinite for
//! any), `tirFile` (u32 length + UTF-8
//! bytes) and which parameters the importer set (u8 each, by parameter), then an FNV-1a 64
//! checksum of everything before it.

use crate::physics::friction::{Direction, Group, HighOrderSubsteps, MAX_BRANCHES, SliderState};
use crate::physics::{FrictionLaw, Input, ModelKind, Parameter, Parameters};

use super::state_machine::Phase;
use super::variables::GUID;

const MAGIC: &[u8; 8] = b"TIRELAG\0";
const FORMAT_VERSION: u32 = 5;

/// The friction's part of an FMU state.
#[derive(Clone, Debug, PartialEq)]
pub struct FrictionState {
    pub sliders: SliderState,
    /// How long the eighth-order pair's first two substeps of the next step may be: a
    /// step's values depend on them to rounding.
    pub high_order_substeps: HighOrderSubsteps,
}

/// A complete copy of an instance's simulation state.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    pub phase: Phase,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub parameters: Parameters,
    pub inputs: [f64; Input::COUNT],
    pub input_rates: [f64; Input::COUNT],
    pub states: Vec<f64>,
    /// The friction's state (none for the Unlimited law).
    pub friction: Option<FrictionState>,
    /// `tirFile` as the importer set it.
    pub tire_data_file: String,
    /// By parameter: whether the importer set it.
    pub set_by_importer: [bool; Parameter::COUNT],
}

fn checksum(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |hash, &b| {
        (hash ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

impl Snapshot {
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(256);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        out.extend_from_slice(&(GUID.len() as u32).to_le_bytes());
        out.extend_from_slice(GUID.as_bytes());
        out.push(self.phase as u8);
        out.push(self.parameters.model as u8);
        out.push(self.parameters.friction as u8);
        let stop_defined = self.stop_time.is_some();
        let mut reals = vec![self.time, self.start_time];
        out.push(u8::from(stop_defined));
        reals.push(self.stop_time.unwrap_or(0.0));
        reals.extend(Parameter::ALL.iter().map(|&p| self.parameters.get(p)));
        reals.extend_from_slice(&self.inputs);
        reals.extend_from_slice(&self.input_rates);
        for value in reals {
            out.extend_from_slice(&value.to_le_bytes());
        }
        out.extend_from_slice(&(self.states.len() as u32).to_le_bytes());
        for value in &self.states {
            out.extend_from_slice(&value.to_le_bytes());
        }
        out.push(u8::from(self.friction.is_some()));
        if let Some(friction) = &self.friction {
            for value in friction.sliders.offsets.iter().flatten() {
                out.extend_from_slice(&value.to_le_bytes());
            }
            out.extend(friction.sliders.sliding.iter().flatten().map(|&s| u8::from(s)));
            for length in friction.high_order_substeps {
                out.extend_from_slice(&length.to_le_bytes());
            }
        }
        out.extend_from_slice(&(self.tire_data_file.len() as u32).to_le_bytes());
        out.extend_from_slice(self.tire_data_file.as_bytes());
        out.extend(self.set_by_importer.iter().map(|&s| u8::from(s)));
        let sum = checksum(&out);
        out.extend_from_slice(&sum.to_le_bytes());
        out
    }

    /// Reads a serialized state, checking everything: a corrupt, truncated or foreign
    /// byte string gives an error that says what is wrong.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        if bytes.len() < MAGIC.len() + 8 || &bytes[..MAGIC.len()] != MAGIC {
            return Err("not a TireLag FMU state (wrong magic bytes)".into());
        }
        let (body, sum) = bytes.split_at(bytes.len() - 8);
        let expected = u64::from_le_bytes(sum.try_into().expect("8 bytes"));
        if checksum(body) != expected {
            return Err("the FMU state is corrupt or truncated (checksum mismatch)".into());
        }
        let mut r = Reader {
            bytes: body,
            at: MAGIC.len(),
        };
        let version = r.u32()?;
        if version != FORMAT_VERSION {
            return Err(format!(
                "FMU state format version {version}; this FMU reads version {FORMAT_VERSION}"
            ));
        }
        let guid_len = r.u32()? as usize;
        let guid = r.take(guid_len)?;
        if guid != GUID.as_bytes() {
            return Err(format!(
                "the FMU state belongs to another FMU (GUID {}, expected {GUID})",
                String::from_utf8_lossy(guid)
            ));
        }
        let phase_code = r.u8()?;
        let phase = Phase::from_code(phase_code).ok_or(format!("unknown phase code {phase_code}"))?;
        let model_code = r.u8()?;
        let model =
            ModelKind::from_value(i64::from(model_code)).ok_or(format!("unknown model {model_code}"))?;
        let friction_code = r.u8()?;
        let friction = FrictionLaw::from_value(i64::from(friction_code))
            .ok_or(format!("unknown friction law {friction_code}"))?;
        let stop_defined = r.u8()? != 0;
        let time = r.f64()?;
        let start_time = r.f64()?;
        let stop_time = r.f64()?;
        let mut parameters = Parameters::default().with_model(model).with_friction(friction);
        for p in Parameter::ALL {
            parameters.set(p, r.f64()?).map_err(|e| e.to_string())?;
        }
        let mut inputs = [0.0; Input::COUNT];
        let mut input_rates = [0.0; Input::COUNT];
        for value in inputs.iter_mut().chain(input_rates.iter_mut()) {
            *value = r.f64()?;
        }
        let count = r.u32()? as usize;
        let expected_count = model.equations().state_names().len();
        if count != expected_count {
            return Err(format!(
                "{count} states for the {} model, which has {expected_count}",
                model.name()
            ));
        }
        let states = (0..count).map(|_| r.f64()).collect::<Result<Vec<_>, _>>()?;
        let friction = match r.u8()? {
            0 if friction == FrictionLaw::Unlimited => None,
            1 if friction != FrictionLaw::Unlimited => {
                let mut sliders = SliderState::AT_REST;
                for value in sliders.offsets.iter_mut().flatten() {
                    *value = r.f64()?;
                }
                for flag in sliders.sliding.iter_mut().flatten() {
                    *flag = match r.u8()? {
                        0 => false,
                        1 => true,
                        other => return Err(format!("sliding flag {other} is neither 0 nor 1")),
                    };
                }
                let mut high_order_substeps = [0.0; 2];
                for length in &mut high_order_substeps {
                    *length = r.f64()?;
                    if length.is_nan() || *length <= 0.0 {
                        return Err(format!(
                            "the substep length {length} in the FMU state is not positive"
                        ));
                    }
                }
                Some(FrictionState {
                    sliders,
                    high_order_substeps,
                })
            }
            flag => {
                return Err(format!(
                    "slider flag {flag} does not fit the {} friction law",
                    friction.name()
                ));
            }
        };
        let file_len = r.u32()? as usize;
        let tire_data_file = std::str::from_utf8(r.take(file_len)?)
            .map_err(|_| "tirFile in the FMU state is not UTF-8".to_owned())?
            .to_owned();
        if tire_data_file.contains('\0') {
            return Err("tirFile in the FMU state holds a NUL byte".into());
        }
        let mut set_by_importer = [false; Parameter::COUNT];
        for flag in &mut set_by_importer {
            *flag = match r.u8()? {
                0 => false,
                1 => true,
                other => return Err(format!("parameter flag {other} is neither 0 nor 1")),
            };
        }
        if r.at != body.len() {
            return Err(format!(
                "{} unexpected bytes at the end of the FMU state",
                body.len() - r.at
            ));
        }
        let all_finite = [time, start_time, stop_time]
            .iter()
            .chain(&inputs)
            .chain(&input_rates)
            .chain(&states)
            .chain(friction.iter().flat_map(|f| f.sliders.offsets.iter().flatten()))
            .all(|v| v.is_finite());
        if !all_finite {
            return Err("the FMU state holds a value that is not finite".into());
        }
        Ok(Snapshot {
            phase,
            time,
            start_time,
            stop_time: stop_defined.then_some(stop_time),
            parameters,
            inputs,
            input_rates,
            states,
            friction,
            tire_data_file,
            set_by_importer,
        })
    }
}

const _: () = assert!(Direction::COUNT * MAX_BRANCHES == 12 && Group::COUNT * MAX_BRANCHES == 8);

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&end| end <= self.bytes.len());
        let end = end.ok_or("the FMU state is truncated")?;
        let slice = &self.bytes[self.at..end];
        self.at = end;
        Ok(slice)
    }
    fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }
    fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Snapshot {
        Snapshot {
            phase: Phase::StepComplete,
            time: 1.25,
            start_time: 0.0,
            stop_time: Some(10.0),
            parameters: Parameters::default().with_model(ModelKind::RingBody),
            inputs: [1.0, -0.2, 0.1, 0.05, 40000.0],
            input_rates: [0.0, 0.5, 0.0, 0.0, 0.0],
            states: vec![1e-3, -2e-3, 0.1, 4e-4, 5e-5, -0.2],
            friction: Some(FrictionState {
                sliders: SliderState {
                    offsets: [[1e-3, 2e-3, 3e-3, 4e-3], [-1e-3, 0.0, 5e-4, 0.1], [0.0; 4]],
                    sliding: [[true, false, false, true], [false; 4]],
                },
                high_order_substeps: [3.5e-4, f64::INFINITY],
            }),
            tire_data_file: "tires/front ü.tir".into(),
            set_by_importer: std::array::from_fn(|k| k % 3 == 0),
        }
    }

    #[test]
    fn round_trips_bit_for_bit() {
        let s = sample();
        let bytes = s.to_bytes();
        assert_eq!(Snapshot::from_bytes(&bytes).unwrap(), s);
        assert_eq!(Snapshot::from_bytes(&bytes).unwrap().to_bytes(), bytes);
    }

    #[test]
    fn rejects_every_truncation_and_every_flipped_byte() {
        let bytes = sample().to_bytes();
        for len in 0..bytes.len() {
            assert!(Snapshot::from_bytes(&bytes[..len]).is_err(), "truncated to {len}");
        }
        for i in 0..bytes.len() {
            let mut corrupt = bytes.clone();
            corrupt[i] ^= 0x10;
            assert!(Snapshot::from_bytes(&corrupt).is_err(), "byte {i} flipped");
        }
    }

    #[test]
    fn refuses_a_substep_length_that_is_not_positive() {
        for which in 0..2 {
            for bad in [0.0, -1e-3, f64::NAN, f64::NEG_INFINITY] {
                let mut s = sample();
                s.friction.as_mut().expect("friction").high_order_substeps[which] = bad;
                let refused = Snapshot::from_bytes(&s.to_bytes()).unwrap_err();
                assert!(refused.contains("substep length"), "{bad}: {refused}");
            }
        }
        let mut any = sample();
        any.friction.as_mut().expect("friction").high_order_substeps = crate::physics::friction::NOT_CARRIED;
        assert_eq!(Snapshot::from_bytes(&any.to_bytes()).unwrap(), any);
    }

    #[test]
    fn names_the_problem() {
        assert!(
            Snapshot::from_bytes(b"hello world, not a state")
                .unwrap_err()
                .contains("magic")
        );
        let mut bytes = sample().to_bytes();
        let n = bytes.len();
        bytes[n - 9] ^= 1;
        assert!(Snapshot::from_bytes(&bytes).unwrap_err().contains("checksum"));
    }
}
