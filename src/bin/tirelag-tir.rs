//! Prints how a tire property file (`.tir`) maps to TireLag's parameters
//! (docs/specification.md 10) and writes the mapping as an SSP parameter set.
//!
//! ```text
//! tirelag-tir FILE.tir [--ssv OUT.ssv]
//! ```
//!
//! Each line: the parameter, its value and unit, the formula and the keys it came from.
//! Parameters the file does not hold keep the FMU's values. Exit status 2 on a file that
//! cannot be used, with the reason (the line or key and value).

use std::path::PathBuf;
use std::process::ExitCode;

use tirelag::tire_data::{self, ssv};

fn usage() -> ExitCode {
    eprintln!("usage: tirelag-tir FILE.tir [--ssv OUT.ssv]");
    ExitCode::from(2)
}

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let (mut file, mut ssv_path) = (None, None);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--ssv" => match args.next() {
                Some(path) => ssv_path = Some(PathBuf::from(path)),
                None => return usage(),
            },
            "-h" | "--help" => {
                println!("usage: tirelag-tir FILE.tir [--ssv OUT.ssv]");
                return ExitCode::SUCCESS;
            }
            _ if file.is_none() && !arg.starts_with('-') => file = Some(PathBuf::from(arg)),
            _ => return usage(),
        }
    }
    let Some(file) = file else { return usage() };
    let mapping = match tire_data::read(&file) {
        Ok(mapping) => mapping,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    println!("{}: {} parameters", file.display(), mapping.values.len());
    for mapped in &mapping.values {
        let name = mapped.parameter.name();
        let unit = mapped.parameter.unit();
        println!("  {name:<18} {:>14.6} {unit:<6} {}", mapped.value, mapped.source);
    }
    for note in &mapping.notes {
        println!("  note: {note}");
    }
    println!("  (the others keep the FMU's values)");
    if let Some(path) = ssv_path {
        let name = file
            .file_stem()
            .map_or("tire".into(), |s| s.to_string_lossy().into_owned());
        if let Err(e) = std::fs::write(&path, ssv::parameter_set(&name, &mapping.values)) {
            eprintln!("cannot write {}: {e}", path.display());
            return ExitCode::from(2);
        }
        println!("wrote {}", path.display());
    }
    ExitCode::SUCCESS
}
