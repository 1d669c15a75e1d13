//! The packed libraries load on every Linux from the manylinux2014 baseline on (docs/specification.md 1,
//! 1b): read from the ELF files inside the FMUs themselves, the x86_64 one (`linux64`,
//! `x86_64-linux`) and the aarch64 one (`aarch64-linux`, FMI 3.0 only) need no glibc
//! symbol version above GLIBC_2.17 and no library but libc, libm, libdl, libpthread, librt,
//! libgcc_s and the dynamic loader.
//!
//! The ELF is read here by hand (64-bit little-endian, as both Linux binaries are):
//! the dynamic section's DT_NEEDED entries and the version-needs section
//! (SHT_GNU_verneed), whose auxiliary entries name every symbol version the library asks
//! of each library it needs.

mod support;

use std::io::Read;

/// The libraries an FMU for manylinux2014 may need, beside its CPU's dynamic loader.
const ALLOWED_LIBRARIES: [&str; 6] = [
    "libc.so.6",
    "libm.so.6",
    "libdl.so.2",
    "libpthread.so.0",
    "librt.so.1",
    "libgcc_s.so.1",
];

/// The CPUs of the Linux binaries: (ELF e_machine, the dynamic loader's name).
const X86_64: (u16, &str) = (62, "ld-linux-x86-64.so.2");
const AARCH64: (u16, &str) = (183, "ld-linux-aarch64.so.1");

fn allowed(library: &str, loader: &str) -> bool {
    library == loader || ALLOWED_LIBRARIES.contains(&library)
}

/// The newest glibc symbol version the library may need.
const NEWEST_GLIBC: (u32, u32) = (2, 17);

const SHT_DYNAMIC: u32 = 6;
const SHT_GNU_VERNEED: u32 = 0x6fff_fffe;
const DT_NULL: u64 = 0;
const DT_NEEDED: u64 = 1;

/// A 64-bit little-endian ELF file, read only as far as the dynamic linking needs.
struct Elf<'a> {
    bytes: &'a [u8],
}

/// One section header's fields that the reading below uses.
struct Section {
    kind: u32,
    offset: usize,
    size: usize,
    /// The section whose strings this one's names index.
    link: usize,
    /// For SHT_GNU_verneed: the number of entries.
    info: usize,
}

impl<'a> Elf<'a> {
    fn new(bytes: &'a [u8], machine: u16) -> Self {
        assert!(bytes.len() >= 64 && bytes[..4] == *b"\x7fELF", "not an ELF file");
        assert_eq!(bytes[4], 2, "not a 64-bit ELF file (EI_CLASS)");
        assert_eq!(bytes[5], 1, "not a little-endian ELF file (EI_DATA)");
        let elf = Self { bytes };
        assert_eq!(elf.u16(16), 3, "not a shared object (e_type ET_DYN)");
        assert_eq!(elf.u16(18), machine, "built for another CPU (e_machine)");
        elf
    }

    fn u16(&self, at: usize) -> u16 {
        u16::from_le_bytes(self.bytes[at..at + 2].try_into().unwrap())
    }

    fn u32(&self, at: usize) -> u32 {
        u32::from_le_bytes(self.bytes[at..at + 4].try_into().unwrap())
    }

    fn u64(&self, at: usize) -> u64 {
        u64::from_le_bytes(self.bytes[at..at + 8].try_into().unwrap())
    }

    fn sections(&self) -> Vec<Section> {
        let table = self.u64(0x28) as usize;
        let entry_size = self.u16(0x3a) as usize;
        let count = self.u16(0x3c) as usize;
        (0..count)
            .map(|i| {
                let at = table + i * entry_size;
                Section {
                    kind: self.u32(at + 4),
                    offset: self.u64(at + 0x18) as usize,
                    size: self.u64(at + 0x20) as usize,
                    link: self.u32(at + 0x28) as usize,
                    info: self.u32(at + 0x2c) as usize,
                }
            })
            .collect()
    }

    /// The NUL-terminated string at `index` of the string table `strings`.
    fn string(&self, strings: &Section, index: usize) -> String {
        let start = strings.offset + index;
        let end = start
            + self.bytes[start..strings.offset + strings.size]
                .iter()
                .position(|&b| b == 0)
                .expect("strings are NUL-terminated");
        String::from_utf8_lossy(&self.bytes[start..end]).into_owned()
    }

    fn section_of_kind(&self, kind: u32) -> Option<Section> {
        self.sections().into_iter().find(|s| s.kind == kind)
    }

    /// The DT_NEEDED entries of the dynamic section: the libraries the loader must find.
    fn needed_libraries(&self) -> Vec<String> {
        let sections = self.sections();
        let dynamic = self
            .section_of_kind(SHT_DYNAMIC)
            .expect("a shared library has a dynamic section");
        let strings = &sections[dynamic.link];
        let mut needed = Vec::new();
        for entry in (dynamic.offset..dynamic.offset + dynamic.size).step_by(16) {
            match self.u64(entry) {
                DT_NULL => break,
                DT_NEEDED => needed.push(self.string(strings, self.u64(entry + 8) as usize)),
                _ => {}
            }
        }
        needed
    }

    /// (library, version) for every symbol version the library needs (Elf64_Verneed and
    /// its Elf64_Vernaux entries).
    fn needed_versions(&self) -> Vec<(String, String)> {
        let sections = self.sections();
        let Some(needs) = self.section_of_kind(SHT_GNU_VERNEED) else {
            return Vec::new();
        };
        let strings = &sections[needs.link];
        let mut versions = Vec::new();
        let mut need = needs.offset;
        for _ in 0..needs.info {
            let auxiliary_count = self.u16(need + 2) as usize;
            let library = self.string(strings, self.u32(need + 4) as usize);
            let mut auxiliary = need + self.u32(need + 8) as usize;
            for _ in 0..auxiliary_count {
                let name = self.string(strings, self.u32(auxiliary + 8) as usize);
                versions.push((library.clone(), name));
                auxiliary += self.u32(auxiliary + 12) as usize;
            }
            need += self.u32(need + 12) as usize;
        }
        versions
    }
}

/// `GLIBC_2.14` as (2, 14); None for other version names (GCC_3.0, GLIBC_PRIVATE, ...).
fn glibc_version(name: &str) -> Option<(u32, u32)> {
    let numbers = name.strip_prefix("GLIBC_")?;
    let mut parts = numbers.split('.').map(|p| p.parse::<u32>().ok());
    let major = parts.next()??;
    let minor = parts.next().flatten().unwrap_or(0);
    Some((major, minor))
}

/// The library exactly as packed: `binaries/linux64/TireLag.so` inside the FMU archive.
fn packed_library() -> Vec<u8> {
    library_in(
        "TIRELAG_FMU",
        "target/fmu/TireLag.fmu",
        "binaries/linux64/TireLag.so",
    )
}

/// The entry `name` of the FMU archive at `relative` (or the path in `env_var`).
fn library_in(env_var: &str, relative: &str, name: &str) -> Vec<u8> {
    let fmu = support::packed_artifact(env_var, relative);
    let mut archive =
        zip::ZipArchive::new(std::fs::File::open(&fmu).unwrap()).expect("the FMU is a zip archive");
    let mut entry = archive
        .by_name(name)
        .unwrap_or_else(|_| panic!("{} holds {name}", fmu.display()));
    let mut bytes = Vec::new();
    entry.read_to_end(&mut bytes).unwrap();
    bytes
}

/// The FMI 3.0 FMU ships the very same library (it exports both versions' functions), so
/// everything checked here holds for it too.
#[test]
fn the_fmi3_fmu_packs_the_same_library() {
    let fmi3 = library_in(
        "TIRELAG_FMU3",
        "target/fmu/fmi3/TireLag.fmu",
        "binaries/x86_64-linux/TireLag.so",
    );
    assert!(fmi3 == packed_library(), "the two FMUs hold different libraries");
}

fn assert_needs_only_the_manylinux2014_libraries(bytes: &[u8], (machine, loader): (u16, &str)) {
    let needed = Elf::new(bytes, machine).needed_libraries();
    println!("needed libraries: {needed:?}");
    assert!(
        needed.iter().any(|l| l == "libc.so.6"),
        "no libc among {needed:?}"
    );
    let others: Vec<_> = needed.iter().filter(|l| !allowed(l, loader)).collect();
    assert!(
        others.is_empty(),
        "the library needs {others:?}, beyond the manylinux2014 set {ALLOWED_LIBRARIES:?} and {loader}"
    );
}

fn assert_needs_no_glibc_symbol_newer_than_2_17(bytes: &[u8], (machine, loader): (u16, &str)) {
    let versions = Elf::new(bytes, machine).needed_versions();
    println!("needed symbol versions: {versions:?}");
    assert!(
        versions.iter().any(|(_, v)| glibc_version(v).is_some()),
        "no GLIBC_ version needs found: the version-needs section was not read"
    );
    let too_new: Vec<_> = versions
        .iter()
        .filter(|(_, v)| v == "GLIBC_PRIVATE" || glibc_version(v).is_some_and(|g| g > NEWEST_GLIBC))
        .collect();
    assert!(
        too_new.is_empty(),
        "the library needs {too_new:?}; at most GLIBC_{}.{} loads on manylinux2014 systems",
        NEWEST_GLIBC.0,
        NEWEST_GLIBC.1
    );
    let unknown_libraries: Vec<_> = versions
        .iter()
        .filter(|(library, _)| !allowed(library, loader))
        .collect();
    assert!(
        unknown_libraries.is_empty(),
        "versions of other libraries: {unknown_libraries:?}"
    );
}

#[test]
fn the_packed_library_needs_only_the_manylinux2014_libraries() {
    assert_needs_only_the_manylinux2014_libraries(&packed_library(), X86_64);
}

#[test]
fn the_packed_library_needs_no_glibc_symbol_newer_than_2_17() {
    assert_needs_no_glibc_symbol_newer_than_2_17(&packed_library(), X86_64);
}

/// The Linux aarch64 library of the FMI 3.0 FMU, when it was packed (not with `--native`).
fn aarch64_library() -> Option<Vec<u8>> {
    support::platform_binary(
        "TIRELAG_FMU3",
        "target/fmu/fmi3/TireLag.fmu",
        "binaries/aarch64-linux/TireLag.so",
    )
}

#[test]
fn the_aarch64_library_needs_only_the_manylinux2014_libraries() {
    if let Some(bytes) = aarch64_library() {
        assert_needs_only_the_manylinux2014_libraries(&bytes, AARCH64);
    }
}

#[test]
fn the_aarch64_library_needs_no_glibc_symbol_newer_than_2_17() {
    if let Some(bytes) = aarch64_library() {
        assert_needs_no_glibc_symbol_newer_than_2_17(&bytes, AARCH64);
    }
}

#[test]
fn glibc_version_names_are_ordered_by_number() {
    assert_eq!(glibc_version("GLIBC_2.2.5"), Some((2, 2)));
    assert_eq!(glibc_version("GLIBC_2.17"), Some((2, 17)));
    assert!(glibc_version("GLIBC_2.34").unwrap() > NEWEST_GLIBC);
    assert!(glibc_version("GLIBC_2.3.4").unwrap() < NEWEST_GLIBC);
    assert_eq!(glibc_version("GCC_3.0"), None);
}
