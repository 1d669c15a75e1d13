//! Measured data: a CSV file with a `time` column, any of the inputs (vx, vy, steerRate,
//! vsx, Fz; a missing one is 0, a missing Fz follows the nominal load) and any of the
//! force outputs (Fx, Fy, Mz). Lines starting with `#` are comments. Any other column is an
//! error: a misspelt input would otherwise be read as 0 and fitted as such.

use crate::physics::{Input, Output};

/// The outputs a fit can compare.
pub const FITTED_OUTPUTS: [Output; 3] = [Output::Fx, Output::Fy, Output::Mz];

/// A measured run: the sample times, the inputs over each sample interval, and the
/// measured outputs at each sample time.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurements {
    pub time: Vec<f64>,
    /// By [`Input`]; `None` where the file has no column.
    pub inputs: [Option<Vec<f64>>; Input::COUNT],
    pub outputs: Vec<(Output, Vec<f64>)>,
}

fn input_name(input: Input) -> &'static str {
    match input {
        Input::Vx => "vx",
        Input::Vy => "vy",
        Input::SteerRate => "steerRate",
        Input::Vsx => "vsx",
        Input::Fz => "Fz",
    }
}

fn output_name(output: Output) -> &'static str {
    match output {
        Output::Fx => "Fx",
        Output::Fy => "Fy",
        Output::Mz => "Mz",
        _ => "",
    }
}

/// The header's names, in the order the error message lists them.
fn known_columns() -> impl Iterator<Item = &'static str> {
    std::iter::once("time")
        .chain(Input::ALL.map(input_name))
        .chain(FITTED_OUTPUTS.map(output_name))
}

/// Every column must be one the fit reads, and only once.
fn check_column_names(names: &[&str]) -> Result<(), String> {
    for (k, name) in names.iter().enumerate() {
        if !known_columns().any(|known| known == *name) {
            return Err(format!(
                "header column {} is '{name}', which is not a column the fit reads; expected time, \
                 an input ({}) or a measured output ({}), spelt exactly so",
                k + 1,
                Input::ALL.map(input_name).join(", "),
                FITTED_OUTPUTS.map(output_name).join(", ")
            ));
        }
        if names[..k].contains(name) {
            return Err(format!(
                "header column {} is '{name}' again: each column may appear once",
                k + 1
            ));
        }
    }
    Ok(())
}

impl Measurements {
    /// Reads the CSV text; every error names the line.
    pub fn parse(text: &str) -> Result<Measurements, String> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let (_, header) = lines.next().ok_or("the file has no header line")?;
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        check_column_names(&names)?;
        let column = |name: &str| names.iter().position(|n| *n == name);
        let time_column = column("time").ok_or("the header has no 'time' column")?;
        let mut rows: Vec<Vec<f64>> = Vec::new();
        for (index, line) in lines {
            let values: Result<Vec<f64>, _> = line.split(',').map(|v| v.trim().parse::<f64>()).collect();
            let values =
                values.map_err(|_| format!("line {}: '{line}' is not a row of numbers", index + 1))?;
            if values.len() != names.len() || values.iter().any(|v| !v.is_finite()) {
                return Err(format!(
                    "line {}: {} values for {} columns, or a value that is not finite",
                    index + 1,
                    values.len(),
                    names.len()
                ));
            }
            rows.push(values);
        }
        if rows.len() < 2 {
            return Err("fewer than two rows of data".into());
        }
        let series = |c: usize| rows.iter().map(|r| r[c]).collect::<Vec<f64>>();
        let time = series(time_column);
        if let Some(k) = time.windows(2).position(|w| w[1] <= w[0]) {
            return Err(format!("time must increase: {} after {}", time[k + 1], time[k]));
        }
        let inputs = Input::ALL.map(|input| column(input_name(input)).map(series));
        let outputs: Vec<(Output, Vec<f64>)> = FITTED_OUTPUTS
            .iter()
            .filter_map(|&o| column(output_name(o)).map(|c| (o, series(c))))
            .collect();
        if outputs.is_empty() {
            return Err("the header names none of the outputs Fx, Fy, Mz".into());
        }
        Ok(Measurements {
            time,
            inputs,
            outputs,
        })
    }

    /// Measured values in all, over every output.
    pub fn len(&self) -> usize {
        self.outputs.len() * self.time.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn output_names(&self) -> Vec<&'static str> {
        self.outputs.iter().map(|(o, _)| output_name(*o)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_columns_by_name() {
        let m = Measurements::parse("# a comment\ntime, vy, Fy\n0, 0.1, 0\n0.01, 0.1, 12.5\n").unwrap();
        assert_eq!(m.time, vec![0.0, 0.01]);
        assert_eq!(m.inputs[Input::Vy as usize], Some(vec![0.1, 0.1]));
        assert_eq!(m.inputs[Input::Vx as usize], None);
        assert_eq!(m.outputs, vec![(Output::Fy, vec![0.0, 12.5])]);
        assert!(
            Measurements::parse("time,Fy\n0,1\n0,2\n")
                .unwrap_err()
                .contains("increase")
        );
        assert!(
            Measurements::parse("time,Fy\n0,1\n0.1,x\n")
                .unwrap_err()
                .contains("line 3")
        );
    }

    #[test]
    fn an_unknown_column_is_named_with_the_accepted_ones() {
        let error = Measurements::parse("time,vx,vyy,Fy\n0,10,0.1,0\n0.01,10,0.1,12.5\n").unwrap_err();
        assert!(error.contains("column 3 is 'vyy'"), "{error}");
        assert!(
            error.contains(
                "expected time, an input (vx, vy, steerRate, vsx, Fz) or a measured output (Fx, Fy, Mz)"
            ),
            "{error}"
        );
        // Names are matched exactly: a capitalised one is unknown too.
        let error = Measurements::parse("Time,Fy\n0,1\n0.1,2\n").unwrap_err();
        assert!(error.contains("column 1 is 'Time'"), "{error}");
        let error = Measurements::parse("time,vy,Fy,vy\n0,1,2,1\n0.1,1,3,1\n").unwrap_err();
        assert!(error.contains("column 4 is 'vy' again"), "{error}");
        // Every known column together is accepted.
        let all = known_columns().collect::<Vec<_>>().join(",");
        let rows = ["0", "0.1"].map(|t| format!("{t}{}", ",1".repeat(known_columns().count() - 1)));
        let m = Measurements::parse(&format!("{all}\n{}\n{}\n", rows[0], rows[1])).unwrap();
        assert!(m.inputs.iter().all(Option::is_some));
        assert_eq!(m.output_names(), vec!["Fx", "Fy", "Mz"]);
    }
}
