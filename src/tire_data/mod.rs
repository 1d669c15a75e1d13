//! Tire data in (docs/specification.md 10): MF-Tyre/Pacejka property files (`.tir`) read
//! ([`tir`]) and mapped to TireLag's parameters ([`mapping`]), and parameter sets written
//! for tools that take them ([`ssv`]). Plain Rust, no FFI: the FMU reads a file given in
//! `tirFile` with it, and the `tirelag-tir` command prints a file's mapping.

pub mod mapping;
pub mod ssv;
pub mod tir;

use std::fmt;
use std::path::Path;

pub use mapping::{Mapped, Mapping};
pub use tir::TirFile;

/// Why a property file could not be used: the file, and what is wrong (with the line or
/// key and value where one is to blame).
#[derive(Clone, Debug, PartialEq)]
pub struct TireDataError {
    pub file: String,
    pub message: String,
}

impl fmt::Display for TireDataError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "tire property file {}: {}", self.file, self.message)
    }
}

impl std::error::Error for TireDataError {}

/// The largest property file read: real ones are tens of kilobytes.
const MAX_FILE_BYTES: u64 = 16 << 20;

/// Reads and maps the property file at `path`. Only a regular file of at most
/// [`MAX_FILE_BYTES`] is read, so that a device or a pipe named by mistake (`/dev/zero`,
/// a FIFO) is refused instead of blocking initialisation or filling the memory.
pub fn read(path: &Path) -> Result<Mapping, TireDataError> {
    let file = path.display().to_string();
    let error = |message: String| TireDataError {
        file: file.clone(),
        message,
    };
    let metadata = std::fs::metadata(path).map_err(|e| error(format!("cannot be read: {e}")))?;
    if !metadata.is_file() {
        return Err(error("is not a regular file".into()));
    }
    if metadata.len() > MAX_FILE_BYTES {
        return Err(error(format!(
            "has {} bytes, more than the {MAX_FILE_BYTES} a tire property file may have",
            metadata.len()
        )));
    }
    let opened = std::fs::File::open(path).map_err(|e| error(format!("cannot be read: {e}")))?;
    let mut text = Vec::new();
    // Bounded again while reading: the file may grow after its size was read.
    std::io::Read::read_to_end(&mut std::io::Read::take(opened, MAX_FILE_BYTES), &mut text)
        .map_err(|e| error(format!("cannot be read: {e}")))?;
    // Property files are often Latin-1 in their comments: decode byte by byte there.
    let text =
        String::from_utf8(text).unwrap_or_else(|e| e.into_bytes().iter().map(|&b| b as char).collect());
    let parsed = TirFile::parse(&text).map_err(|e| error(e.to_string()))?;
    mapping::map(&parsed).map_err(|e| error(e.to_string()))
}
