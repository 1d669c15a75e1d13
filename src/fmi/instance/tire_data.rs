//! `tirFile` (docs/specification.md 10): the String parameter naming a tire property file, read and mapped
//! at fmi2ExitInitializationMode ([`crate::tire_data`]). A parameter the importer set
//! keeps its value; every other parameter the file maps takes the file's. A file that
//! cannot be used is an fmi2Error naming it and what is wrong, and changes nothing.

use std::ffi::{CStr, CString};
use std::path::{Path, PathBuf};

use super::{Instance, lookup};
use crate::fmi::logger::Category;
use crate::fmi::state_machine::Call;
use crate::fmi::status::{CallResult, Rejection, Status};
use crate::fmi::variables::{Role, ValueType};

/// The path of a `file:` URI (`file:///a/b`, `file:/a/b`, `file://localhost/a/b`), with
/// its percent escapes decoded; `None` for another scheme or host.
pub fn path_of_file_uri(uri: &str) -> Option<PathBuf> {
    let rest = uri.strip_prefix("file:")?;
    let path = match rest.strip_prefix("//") {
        Some(authority_and_path) => {
            let slash = authority_and_path.find('/')?;
            let host = &authority_and_path[..slash];
            if !(host.is_empty() || host.eq_ignore_ascii_case("localhost")) {
                return None;
            }
            &authority_and_path[slash..]
        }
        None => rest,
    };
    let bytes = path.as_bytes();
    let mut decoded = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let escape = (bytes[i] == b'%')
            .then(|| bytes.get(i + 1..i + 3))
            .flatten()
            .and_then(|hex| u8::from_str_radix(std::str::from_utf8(hex).ok()?, 16).ok());
        match escape {
            Some(byte) => {
                decoded.push(byte);
                i += 3;
            }
            None => {
                decoded.push(bytes[i]);
                i += 1;
            }
        }
    }
    String::from_utf8(decoded).ok().map(PathBuf::from)
}

impl Instance {
    /// Where `tirFile` points: an absolute path, a `file:` URI, or a relative path, looked
    /// up first in the FMU's resources folder (if the importer gave one and the file is
    /// there: a file shipped inside the FMU) and then in the process's current working
    /// directory (where a user running a simulation keeps their own files).
    fn tire_data_path(&self, given: &str) -> CallResult<PathBuf> {
        if given.starts_with("file:") {
            return path_of_file_uri(given)
                .ok_or_else(|| Rejection::error(format!("tirFile '{given}' is not a local file: URI")));
        }
        let path = Path::new(given);
        if path.is_absolute() {
            return Ok(path.to_owned());
        }
        let mut tried = Vec::new();
        let mut not_tried = Vec::new();
        match &self.resources {
            Some(resources) => tried.push((resources.join(path), "the FMU's resources folder")),
            None => not_tried.push("no resources folder (the importer gave none)".to_owned()),
        }
        match std::env::current_dir() {
            Ok(directory) => tried.push((directory.join(path), "the current working directory")),
            Err(e) => not_tried.push(format!("no current working directory ({e})")),
        }
        if let Some((found, _)) = tried.iter().find(|(candidate, _)| candidate.exists()) {
            return Ok(found.clone());
        }
        let places: Vec<String> = tried
            .iter()
            .map(|(candidate, place)| format!("{} ({place})", candidate.display()))
            .chain(not_tried)
            .collect();
        let message = format!(
            "tirFile '{given}' is a relative path, looked up in the FMU's resources folder and then \
             in the current working directory, and found in neither: tried {}",
            places.join("; ")
        );
        Err(Rejection::error(message))
    }

    /// Reads `tirFile`, if set, into the parameters the importer did not set; checks them
    /// together. On error nothing changes.
    pub(super) fn apply_tire_data(&mut self) -> CallResult {
        let given = self.tire_data_file.to_string_lossy().into_owned();
        if given.is_empty() {
            return Ok(());
        }
        let path = self.tire_data_path(&given)?;
        let mapping = crate::tire_data::read(&path).map_err(|e| Rejection::error(e.to_string()))?;
        let mut parameters = self.parameters.clone();
        let mut kept = Vec::new();
        for mapped in &mapping.values {
            if self.set_by_importer[mapped.parameter as usize] {
                kept.push(mapped.parameter.name());
            } else {
                parameters
                    .set(mapped.parameter, mapped.value)
                    .map_err(|e| Rejection::error(format!("tire property file {}: {e}", path.display())))?;
            }
        }
        parameters.validate().map_err(|e| {
            Rejection::error(format!(
                "tire property file {}: its values do not fit the other parameters: {e}",
                path.display()
            ))
        })?;
        self.parameters = parameters;
        self.parameters_changed = true;
        let mut summary = format!(
            "tirFile {}: {} parameters mapped",
            path.display(),
            mapping.values.len() - kept.len()
        );
        if !kept.is_empty() {
            summary += &format!("; set by the importer, kept: {}", kept.join(", "));
        }
        for note in std::iter::once(&summary).chain(&mapping.notes) {
            self.logger.log(Status::Ok, Category::All, note);
        }
        Ok(())
    }

    /// The value of `tirFile` for fmi2GetString: valid until it is set again or the
    /// instance is freed.
    pub fn get_string(
        &mut self,
        value_references: &[u32],
        values: &mut [*const std::ffi::c_char],
    ) -> CallResult {
        self.require(Call::GetValues)?;
        super::same_length("values", value_references.len(), values.len())?;
        for (&vr, value) in value_references.iter().zip(values.iter_mut()) {
            let Role::TireDataFile = lookup(vr, ValueType::String)?.role() else {
                unreachable!("tirFile is the only String variable")
            };
            *value = self.tire_data_file.as_ptr();
        }
        Ok(())
    }

    /// Sets `tirFile` (before the end of initialisation; after it, only to the value it
    /// has). All or nothing.
    pub fn set_string(&mut self, value_references: &[u32], values: &[&CStr]) -> CallResult {
        self.require(Call::SetValues)?;
        super::same_length("values", value_references.len(), values.len())?;
        for (&vr, value) in value_references.iter().zip(values) {
            lookup(vr, ValueType::String)?;
            if self.phase.running() && *value != self.tire_data_file.as_c_str() {
                return Err(Rejection::error(format!(
                    "cannot set tirFile = '{}': it is a fixed parameter and the FMU is initialised with \
                     tirFile = '{}'",
                    value.to_string_lossy(),
                    self.tire_data_file.to_string_lossy()
                )));
            }
            if value.to_str().is_err() {
                return Err(Rejection::error("tirFile must be UTF-8"));
            }
        }
        if let Some(last) = values.last() {
            self.tire_data_file = CString::from(*last);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_uris_become_paths() {
        for (uri, path) in [
            ("file:///tires/a%20b/tire.tir", Some("/tires/a b/tire.tir")),
            ("file:/tires/tire.tir", Some("/tires/tire.tir")),
            ("file://localhost/tires/tire.tir", Some("/tires/tire.tir")),
            ("file://server/tires/tire.tir", None),
            ("http://example.com/tire.tir", None),
        ] {
            assert_eq!(path_of_file_uri(uri), path.map(PathBuf::from), "{uri}");
        }
    }
}
