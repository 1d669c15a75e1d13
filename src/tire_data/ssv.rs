//! A parameter set as an SSP parameter values file (`.ssv`, SSP 1.0), which fmpy,
//! OMSimulator and libcosim read.

use std::fmt::Write as _;

use super::mapping::Mapped;

/// `text` with the five XML special characters escaped.
fn escaped(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// The values as an SSP parameter set named `name`, each with its source as a description.
pub fn parameter_set(name: &str, values: &[Mapped]) -> String {
    parameter_set_with_selectors(name, &[], values)
}

/// [`parameter_set`] with Integer parameters first (the selectors `tireModel`, `friction`).
pub fn parameter_set_with_selectors(name: &str, integers: &[(&str, i64)], values: &[Mapped]) -> String {
    let mut out = String::new();
    out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        out,
        "<ssv:ParameterSet xmlns:ssc=\"http://ssp-standard.org/SSP1/SystemStructureCommon\" \
         xmlns:ssv=\"http://ssp-standard.org/SSP1/SystemStructureParameterValues\" \
         version=\"1.0\" name=\"{}\">",
        escaped(name)
    );
    out.push_str("  <ssv:Parameters>\n");
    for (name, value) in integers {
        let _ = writeln!(
            out,
            "    <ssv:Parameter name=\"{}\">\n      <ssv:Integer value=\"{value}\"/>\n    </ssv:Parameter>",
            escaped(name)
        );
    }
    for mapped in values {
        let _ = writeln!(
            out,
            "    <ssv:Parameter name=\"{}\" description=\"{}\">\n      <ssv:Real value=\"{:?}\"/>\n    </ssv:Parameter>",
            mapped.parameter.name(),
            escaped(&mapped.source),
            mapped.value
        );
    }
    out.push_str("  </ssv:Parameters>\n</ssv:ParameterSet>\n");
    out
}
