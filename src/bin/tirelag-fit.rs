//! Fits chosen parameters of a chosen model and friction law to a measured run (SPEC 10).
//!
//! ```text
//! tirelag-fit DATA.csv --free Calpha,sigmaY [--model RLT] [--friction Unlimited]
//!             [--tir FILE.tir] [--set NAME=VALUE]... [--bounds NAME=LOW:HIGH]... [--out DIR]
//! ```
//!
//! DATA.csv: `time`, any of the inputs (vx, vy, steerRate, vsx, Fz) and any of Fx, Fy, Mz;
//! row k's inputs hold until the next row, and its outputs are those at its time. The
//! start values are the FMU's defaults, then the property file's, then `--set`'s. It
//! prints its progress, then each value with its 95 % confidence interval and the
//! residuals, and writes DIR/fit.json, DIR/fit.ssv (the fitted set as SSP parameter
//! values) and DIR/fit.csv (measured and fitted outputs) (DIR: fit-out). Exit status 2
//! with the reason where the data or the arguments cannot be used.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use tirelag::fitting::{self, Free, data::Measurements};
use tirelag::physics::{FrictionLaw, ModelKind, Parameter, Parameters};
use tirelag::tire_data::{self, Mapped, ssv};

struct Arguments {
    data: PathBuf,
    free: Vec<Parameter>,
    model: ModelKind,
    friction: FrictionLaw,
    tir: Option<PathBuf>,
    set: Vec<(Parameter, f64)>,
    bounds: Vec<(Parameter, f64, f64)>,
    out: PathBuf,
}

const USAGE: &str = "usage: tirelag-fit DATA.csv --free NAME[,NAME...] [--model RLT|DDT|SecondOrder|RingBody] \
                     [--friction Unlimited|Coulomb|Brush] [--tir FILE.tir] [--set NAME=VALUE]... \
                     [--bounds NAME=LOW:HIGH]... [--out DIR]";

fn parameter(name: &str) -> Result<Parameter, String> {
    Parameter::ALL
        .into_iter()
        .find(|p| p.name() == name)
        .ok_or_else(|| format!("'{name}' is not a parameter"))
}

fn number(text: &str) -> Result<f64, String> {
    text.parse::<f64>()
        .map_err(|_| format!("'{text}' is not a number"))
}

fn parse_arguments() -> Result<Arguments, String> {
    let mut args = std::env::args().skip(1);
    let mut parsed = Arguments {
        data: PathBuf::new(),
        free: Vec::new(),
        model: ModelKind::Rlt,
        friction: FrictionLaw::Unlimited,
        tir: None,
        set: Vec::new(),
        bounds: Vec::new(),
        out: PathBuf::from("fit-out"),
    };
    let mut data = None;
    while let Some(arg) = args.next() {
        let mut value = || args.next().ok_or_else(|| format!("{arg} needs a value"));
        match arg.as_str() {
            "--free" => {
                for name in value()?.split(',') {
                    parsed.free.push(parameter(name.trim())?);
                }
            }
            "--model" => {
                let name = value()?;
                parsed.model = ModelKind::ALL
                    .into_iter()
                    .find(|m| m.name() == name)
                    .ok_or(format!(
                        "'{name}' is not a model: RLT, DDT, SecondOrder or RingBody"
                    ))?;
            }
            "--friction" => {
                let name = value()?;
                parsed.friction = FrictionLaw::ALL
                    .into_iter()
                    .find(|l| l.name() == name)
                    .ok_or(format!(
                        "'{name}' is not a friction law: Unlimited, Coulomb or Brush"
                    ))?;
            }
            "--tir" => parsed.tir = Some(PathBuf::from(value()?)),
            "--out" => parsed.out = PathBuf::from(value()?),
            "--set" => {
                let text = value()?;
                let (name, v) = text.split_once('=').ok_or(format!("--set {text}: NAME=VALUE"))?;
                parsed.set.push((parameter(name)?, number(v)?));
            }
            "--bounds" => {
                let text = value()?;
                let (name, range) = text
                    .split_once('=')
                    .ok_or(format!("--bounds {text}: NAME=LOW:HIGH"))?;
                let (low, high) = range
                    .split_once(':')
                    .ok_or(format!("--bounds {text}: NAME=LOW:HIGH"))?;
                parsed
                    .bounds
                    .push((parameter(name)?, number(low)?, number(high)?));
            }
            _ if data.is_none() && !arg.starts_with('-') => data = Some(PathBuf::from(arg)),
            _ => return Err(format!("unexpected argument '{arg}'")),
        }
    }
    parsed.data = data.ok_or("no data file")?;
    if parsed.free.is_empty() {
        return Err("no free parameters (--free)".into());
    }
    Ok(parsed)
}

fn start_parameters(args: &Arguments) -> Result<Parameters, String> {
    let mut parameters = Parameters::default()
        .with_model(args.model)
        .with_friction(args.friction);
    if let Some(tir) = &args.tir {
        for mapped in tire_data::read(tir).map_err(|e| e.to_string())?.values {
            parameters
                .set(mapped.parameter, mapped.value)
                .map_err(|e| e.to_string())?;
        }
    }
    for &(p, v) in &args.set {
        parameters.set(p, v).map_err(|e| e.to_string())?;
    }
    parameters
        .validate()
        .map_err(|e| format!("the start values do not fit together: {e}"))?;
    Ok(parameters)
}

fn run() -> Result<(), String> {
    let args = parse_arguments()?;
    let text = std::fs::read_to_string(&args.data).map_err(|e| format!("{}: {e}", args.data.display()))?;
    let measurements = Measurements::parse(&text).map_err(|e| format!("{}: {e}", args.data.display()))?;
    let start = start_parameters(&args)?;
    let free: Vec<Free> = args
        .free
        .iter()
        .map(|&p| {
            let mut f = Free::around(p, start.get(p));
            if let Some(&(_, low, high)) = args.bounds.iter().find(|b| b.0 == p) {
                (f.lower, f.upper) = (low, high);
            }
            f
        })
        .collect();
    eprintln!(
        "fitting {} of {} ({}) to {} samples of {} in {}",
        args.free.iter().map(|p| p.name()).collect::<Vec<_>>().join(", "),
        args.model.name(),
        args.friction.name(),
        measurements.time.len(),
        measurements.output_names().join(", "),
        args.data.display()
    );
    let clock = Instant::now();
    let mut progress = |pass: usize, p: fitting::least_squares::Progress| {
        let values: Vec<String> = free
            .iter()
            .zip(p.parameters)
            .map(|(f, v)| format!("{} = {v:.6}", f.parameter.name()))
            .collect();
        eprintln!(
            "  pass {pass} step {:>3}  sum of squares {:.6e}  {}",
            p.iteration,
            p.sum_of_squares,
            values.join("  ")
        );
    };
    let fit = fitting::fit(&start, &free, &measurements, &mut progress)?;
    let seconds = clock.elapsed().as_secs_f64();
    println!(
        "{} simulations of {} samples in {:.1} ms ({} steps)",
        fit.simulations,
        measurements.time.len(),
        1e3 * seconds,
        fit.iterations
    );
    println!(
        "{:<18} {:>14} {:>14}   95 % interval",
        "parameter", "value", "std. error"
    );
    for e in &fit.estimates {
        println!(
            "{:<18} {:>14.6} {:>14.6}   [{:.6}, {:.6}] {}",
            e.parameter.name(),
            e.value,
            e.standard_error,
            e.interval.0,
            e.interval.1,
            e.parameter.unit()
        );
    }
    for (name, rms) in measurements.output_names().iter().zip(&fit.residual_rms) {
        println!("residual rms of {name}: {rms:.6}");
    }
    write_results(&args, &measurements, &fit, seconds)
}

fn write_results(
    args: &Arguments,
    measurements: &Measurements,
    fit: &fitting::Fit,
    seconds: f64,
) -> Result<(), String> {
    let out = &args.out;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let write = |name: &str, text: String| {
        let path = out.join(name);
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))
    };
    let names = measurements.output_names();
    // JSON has no infinity: a parameter the data do not determine has no interval (null).
    let number = |v: f64| {
        if v.is_finite() {
            format!("{v:?}")
        } else {
            "null".into()
        }
    };
    let mut json = String::from("{\n");
    let _ = writeln!(json, "  \"model\": \"{}\",", args.model.name());
    let _ = writeln!(json, "  \"friction\": \"{}\",", args.friction.name());
    json.push_str("  \"estimates\": {\n");
    for (k, e) in fit.estimates.iter().enumerate() {
        let _ = writeln!(
            json,
            "    \"{}\": {{\"value\": {}, \"standard_error\": {}, \"interval\": [{}, {}]}}{}",
            e.parameter.name(),
            number(e.value),
            number(e.standard_error),
            number(e.interval.0),
            number(e.interval.1),
            if k + 1 < fit.estimates.len() { "," } else { "" }
        );
    }
    json.push_str("  },\n  \"residual_rms\": {");
    let rms: Vec<String> = names
        .iter()
        .zip(&fit.residual_rms)
        .map(|(n, r)| format!("\"{n}\": {r:?}"))
        .collect();
    json.push_str(&rms.join(", "));
    json.push_str("},\n  \"parameters\": {");
    let all: Vec<String> = Parameter::ALL
        .iter()
        .map(|p| format!("\"{}\": {:?}", p.name(), fit.parameters.get(*p)))
        .collect();
    json.push_str(&all.join(", "));
    let _ = write!(
        json,
        "}},\n  \"iterations\": {},\n  \"simulations\": {},\n  \"seconds\": {seconds:?}\n}}\n",
        fit.iterations, fit.simulations
    );
    write("fit.json", json)?;

    let mapped: Vec<Mapped> = Parameter::ALL
        .iter()
        .map(|&p| Mapped {
            parameter: p,
            value: fit.parameters.get(p),
            source: match fit.estimates.iter().find(|e| e.parameter == p) {
                Some(e) => format!(
                    "fitted to {}: 95 % interval [{}, {}]",
                    args.data.display(),
                    e.interval.0,
                    e.interval.1
                ),
                None => "held".into(),
            },
        })
        .collect();
    let selectors = [
        ("tireModel", args.model as i64),
        ("friction", args.friction as i64),
    ];
    write(
        "fit.ssv",
        ssv::parameter_set_with_selectors("fit", &selectors, &mapped),
    )?;

    let mut csv = String::from("time");
    for n in &names {
        let _ = write!(csv, ",{n}_measured,{n}_fitted");
    }
    csv.push('\n');
    for (k, t) in measurements.time.iter().enumerate() {
        let _ = write!(csv, "{t:?}");
        for (fitted, (_, measured)) in fit.fitted.iter().zip(&measurements.outputs) {
            let _ = write!(csv, ",{:?},{:?}", measured[k], fitted[k]);
        }
        csv.push('\n');
    }
    write("fit.csv", csv)?;
    println!("wrote {0}/fit.json, {0}/fit.ssv, {0}/fit.csv", out.display());
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tirelag-fit: {e}\n{USAGE}");
            ExitCode::from(2)
        }
    }
}
