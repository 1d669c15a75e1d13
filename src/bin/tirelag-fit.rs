//! Fits chosen parameters of a chosen model and friction law to a measured run
//! (docs/specification.md 10).
//!
//! ```text
//! tirelag-fit DATA.csv --free Calpha,sigmaY [--model RLT] [--friction Unlimited]
//!             [--tir FILE.tir] [--set NAME=VALUE]... [--bounds NAME=LOW:HIGH]... [--out DIR]
//! ```
//!
//! DATA.csv: `time`, any of the inputs (vx, vy, steerRate, vsx, Fz) and any of Fx, Fy, Mz,
//! and no other column; row k's inputs hold until the next row, and its outputs are those
//! at its time. `--help` (or `-h`) prints the usage in full and exits 0. The
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

#[derive(Debug)]
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

/// What the command line asks for.
#[derive(Debug)]
enum Command {
    Help,
    Fit(Arguments),
}

const USAGE: &str = "usage: tirelag-fit DATA.csv --free NAME[,NAME...] [--model RLT|DDT|SecondOrder|RingBody]
                   [--friction Unlimited|Coulomb|Brush] [--tir FILE.tir] [--set NAME=VALUE]...
                   [--bounds NAME=LOW:HIGH]... [--out DIR]";

/// The full usage, for `--help`: every option, the data file's columns, what is written where.
fn help() -> String {
    let mut parameters = String::new();
    let mut line = String::from("   ");
    for p in Parameter::ALL {
        let entry = format!(" {} ({}),", p.name(), p.unit());
        if line.len() + entry.len() > 90 {
            parameters.push_str(&line);
            parameters.push('\n');
            line = String::from("   ");
        }
        line.push_str(&entry);
    }
    parameters.push_str(line.trim_end_matches(','));
    format!(
        "tirelag-fit: fits chosen parameters of a tire model and friction law to a measured run,
simulated with the FMU's exact step (bounded least squares, 95 % confidence intervals).

{USAGE}
       tirelag-fit --help

DATA.csv                 a CSV whose header names its columns: time (s), any of the inputs
                         vx, vy (m/s), steerRate (rad/s), vsx (m/s), Fz (N) and any of the
                         measured outputs Fx, Fy (N), Mz (N.m); no other column. A missing
                         input is 0, a missing Fz the nominal load Fz0. Row k's inputs hold
                         until the next row; its outputs are the tire's at its time. Lines
                         starting with # are comments.
--free NAME[,NAME...]    the parameters to fit (required)
--model M                RLT (default), DDT, SecondOrder or RingBody
--friction L             Unlimited (default), Coulomb or Brush
--tir FILE.tir           start values from a tire property file
--set NAME=VALUE         a start value (repeatable). Start values: the FMU's defaults, then
                         --tir's, then --set's
--bounds NAME=LOW:HIGH   the bounds of a free parameter (repeatable). Without: from a
                         hundredth of its start value to a hundred times it (from 0 where
                         it may be 0; 100 times either side where it may be negative)
--out DIR                where the results go (default fit-out)
-h, --help               prints this and exits

Parameters (NAME):
{parameters}

Writes:
  stderr                 each least-squares step: the sum of squares and the values
  stdout                 each fitted value with its standard error and 95 % interval, and
                         the residual rms of each output
  DIR/fit.json           the estimates (value, standard_error, interval, unit; null where
                         the data do not determine a parameter), the residual rms, every
                         parameter as fitted
  DIR/fit.ssv            the fitted set as SSP parameter values, tireModel and friction
                         included, to load into the FMU
  DIR/fit.csv            time and each output measured and fitted
  DIR/fit.png            measured against fitted: drawn by ./scripts/fit (scripts/fit_plot.py)
                         after this command

Exit status: 0 when fitted, 2 with the reason where the data or the arguments cannot be used."
    )
}

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

/// Reads the arguments (without the program's name). `--help` or `-h` anywhere asks for the
/// help, whatever else is there (./scripts/fit looks for it the same way).
fn parse_arguments(args: Vec<String>) -> Result<Command, String> {
    if args.iter().any(|a| a == "--help" || a == "-h") {
        return Ok(Command::Help);
    }
    let mut args = args.into_iter();
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
    Ok(Command::Fit(parsed))
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
    let args = match parse_arguments(std::env::args().skip(1).collect())? {
        Command::Help => {
            println!("{}", help());
            return Ok(());
        }
        Command::Fit(args) => args,
    };
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
            "    \"{}\": {{\"value\": {}, \"standard_error\": {}, \"interval\": [{}, {}], \"unit\": \"{}\"}}{}",
            e.parameter.name(),
            number(e.value),
            number(e.standard_error),
            number(e.interval.0),
            number(e.interval.1),
            e.parameter.unit(),
            if k + 1 < fit.estimates.len() { "," } else { "" }
        );
    }
    json.push_str("  },\n  \"residual_rms\": {");
    let rms: Vec<String> = names
        .iter()
        .zip(&fit.residual_rms)
        .map(|(n, r)| format!("\"{n}\": {}", number(*r)))
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
            eprintln!("tirelag-fit: {e}\n{USAGE}\n(tirelag-fit --help: every option and what it writes)");
            ExitCode::from(2)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parsed(args: &[&str]) -> Result<Command, String> {
        parse_arguments(args.iter().map(|a| a.to_string()).collect())
    }

    #[test]
    fn help_needs_no_data_file_and_wins_over_everything_else() {
        for args in [
            &["--help"][..],
            &["-h"],
            &["data.csv", "--free", "Calpha", "-h"],
            &["--bogus", "--help"],
        ] {
            assert!(matches!(parsed(args), Ok(Command::Help)), "{args:?}");
        }
        assert!(parsed(&["data.csv"]).unwrap_err().contains("--free"));
        assert!(
            parsed(&["--free", "Calpha"])
                .unwrap_err()
                .contains("no data file")
        );
    }

    #[test]
    fn help_tells_every_option_every_parameter_and_every_file() {
        let text = help();
        for option in [
            "--free",
            "--model",
            "--friction",
            "--tir",
            "--set",
            "--bounds",
            "--out",
            "-h, --help",
        ] {
            assert!(text.contains(option), "{option} missing from\n{text}");
        }
        for p in Parameter::ALL {
            assert!(
                text.contains(&format!(" {} (", p.name())),
                "{} missing from\n{text}",
                p.name()
            );
        }
        for file in [
            "DIR/fit.json",
            "DIR/fit.ssv",
            "DIR/fit.csv",
            "DIR/fit.png",
            "stdout",
            "stderr",
        ] {
            assert!(text.contains(file), "{file} missing from\n{text}");
        }
        assert!(text.lines().all(|l| l.len() <= 100), "{text}");
    }
}
