//! Every binary packed in the two FMUs, read from its file (docs/specification.md 1b): each exports every FMI
//! function of the Linux x86_64 library under its plain C name, needs only the operating
//! system's own libraries, and is built for its platform. The runnable ones are also run
//! (tests/python/test_platforms.py); the macOS ones cannot run here, so these tables are
//! all that is checked of them.
//!
//! Without the other platforms packed (`./scripts/build-fmu --native`) the tests that need
//! them say so and pass; under `./scripts/test` (TIRELAG_ALL_PLATFORMS=1) a missing binary
//! fails.

mod support;

use std::collections::BTreeSet;

use object::read::macho::{LoadCommandVariant, MachOFatFile32, MachOFile64};
use object::read::pe::PeFile64;
use object::{Architecture, LittleEndian, Object, macho};

const FMI2: (&str, &str) = ("TIRELAG_FMU", "target/fmu/TireLag.fmu");
const FMI3: (&str, &str) = ("TIRELAG_FMU3", "target/fmu/fmi3/TireLag.fmu");

/// The FMI 2.0 functions (Co-Simulation and Model Exchange) and the FMI 3.0 ones.
const FMI2_FUNCTIONS: usize = 44;
const FMI3_FUNCTIONS: usize = 75;

/// The DLLs a Windows binary may import: the system's own (no libgcc or libwinpthread, and
/// not bcryptprimitives, whose ProcessPrng Windows 7 and wine 8 lack).
const WINDOWS_LIBRARIES: [&str; 6] = [
    "kernel32.dll",
    "ntdll.dll",
    "advapi32.dll",
    "msvcrt.dll",
    "userenv.dll",
    "ws2_32.dll",
];
const LIB_SYSTEM: &str = "/usr/lib/libSystem.B.dylib";
const INSTALL_NAME: &str = "@rpath/TireLag.dylib";

/// The archive entry `name` of one FMU (see [`support::platform_binary`]).
fn packed((env_var, relative): (&str, &str), name: &str) -> Option<Vec<u8>> {
    support::platform_binary(env_var, relative, name)
}

/// The FMI functions a binary exports, by their C names (Mach-O's leading '_' removed).
fn fmi_exports(file: &object::File) -> BTreeSet<String> {
    let mach_o = matches!(file, object::File::MachO64(_));
    file.exports()
        .expect("the export table reads")
        .filter_map(|e| match e.unwrap().name() {
            object::NameOrOrdinal::Name(name) => Some(String::from_utf8_lossy(name).into_owned()),
            object::NameOrOrdinal::Ordinal(_) => None, // not a plain C name
        })
        .map(|n| {
            if mach_o {
                n.strip_prefix('_').map(str::to_owned).unwrap_or(n)
            } else {
                n
            }
        })
        .filter(|n| n.starts_with("fmi2") || n.starts_with("fmi3"))
        .collect()
}

/// The Linux x86_64 library's FMI functions: the reference every other binary must match.
fn reference_exports() -> BTreeSet<String> {
    let bytes =
        packed(FMI2, "binaries/linux64/TireLag.so").expect("the Linux x86_64 library is always packed");
    let exports = fmi_exports(&object::File::parse(&*bytes).unwrap());
    let count = |prefix| exports.iter().filter(|n| n.starts_with(prefix)).count();
    assert_eq!(
        count("fmi2"),
        FMI2_FUNCTIONS,
        "FMI 2.0 functions exported: {exports:?}"
    );
    assert_eq!(
        count("fmi3"),
        FMI3_FUNCTIONS,
        "FMI 3.0 functions exported: {exports:?}"
    );
    exports
}

fn assert_exports_all(what: &str, file: &object::File, reference: &BTreeSet<String>) {
    let exports = fmi_exports(file);
    let missing: Vec<_> = reference.difference(&exports).collect();
    let extra: Vec<_> = exports.difference(reference).collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "{what}: missing {missing:?}, unexpected {extra:?}"
    );
}

#[test]
fn the_windows_dll_exports_every_fmi_function_and_imports_only_system_dlls() {
    let Some(dll) = packed(FMI2, "binaries/win64/TireLag.dll") else {
        return;
    };
    let fmi3 = packed(FMI3, "binaries/x86_64-windows/TireLag.dll").expect("both FMUs carry Windows");
    assert!(dll == fmi3, "the two FMUs hold different Windows DLLs");

    let file = object::File::parse(&*dll).unwrap();
    assert!(matches!(file, object::File::Pe64(_)), "not a 64-bit PE file");
    assert_eq!(file.architecture(), Architecture::X86_64);
    assert_exports_all("win64/TireLag.dll", &file, &reference_exports());

    let imports: Vec<_> = file.imports().unwrap().map(|i| i.unwrap()).collect();
    let libraries: BTreeSet<String> = imports
        .iter()
        .map(|i| String::from_utf8_lossy(i.library()).to_ascii_lowercase())
        .collect();
    println!("imported DLLs: {libraries:?}");
    assert!(
        libraries.contains("kernel32.dll"),
        "no KERNEL32 among {libraries:?}"
    );
    let others: Vec<_> = libraries
        .iter()
        .filter(|l| !WINDOWS_LIBRARIES.contains(&l.as_str()))
        .collect();
    assert!(
        others.is_empty(),
        "the DLL imports {others:?}, beyond the system's {WINDOWS_LIBRARIES:?}"
    );
    assert!(
        !imports
            .iter()
            .any(|i| i.name() == object::NameOrOrdinal::Name(&b"ProcessPrng"[..])),
        "the DLL imports ProcessPrng, which Windows 7 and wine 8 lack"
    );

    // Reproducible: no link time in the header.
    let pe = PeFile64::parse(&*dll).unwrap();
    assert_eq!(pe.nt_headers().file_header.time_date_stamp.get(LittleEndian), 0);
}

#[test]
fn the_linux_aarch64_library_exports_every_fmi_function() {
    let Some(so) = packed(FMI3, "binaries/aarch64-linux/TireLag.so") else {
        return;
    };
    let file = object::File::parse(&*so).unwrap();
    assert!(matches!(file, object::File::Elf64(_)), "not a 64-bit ELF file");
    assert_eq!(file.architecture(), Architecture::Aarch64);
    assert_exports_all("aarch64-linux/TireLag.so", &file, &reference_exports());
    // Its libraries and glibc versions: tests/portable_binary.rs.
}

/// What a thin Mach-O dylib says of itself: its architecture, the dylibs it loads, its
/// install name, the oldest macOS it runs on (major, minor) and whether it carries a code
/// signature (Apple silicon runs no unsigned code; the linker signs arm64 ad hoc).
struct MachODylib {
    architecture: Architecture,
    signed: bool,
    loads: Vec<String>,
    install_name: Option<String>,
    minimum_macos: Option<(u32, u32)>,
}

fn read_dylib(bytes: &[u8]) -> MachODylib {
    let file = MachOFile64::<LittleEndian>::parse(bytes).expect("a 64-bit little-endian Mach-O file");
    let endian = file.endian();
    let mut dylib = MachODylib {
        architecture: file.architecture(),
        signed: false,
        loads: Vec::new(),
        install_name: None,
        minimum_macos: None,
    };
    let version = |v: macho::Version| (u32::from(v.major()), u32::from(v.minor()));
    let mut commands = file.macho_load_commands().unwrap();
    while let Some(command) = commands.next().unwrap() {
        dylib.signed |= command.cmd() == macho::LC_CODE_SIGNATURE;
        match command.variant().unwrap() {
            LoadCommandVariant::Dylib(d) => {
                let name = command.string(endian, d.dylib.name).unwrap();
                dylib.loads.push(String::from_utf8_lossy(name).into_owned());
            }
            LoadCommandVariant::IdDylib(d) => {
                let name = command.string(endian, d.dylib.name).unwrap();
                dylib.install_name = Some(String::from_utf8_lossy(name).into_owned());
            }
            LoadCommandVariant::BuildVersion(b, _) => {
                assert_eq!(
                    b.platform.get(endian),
                    macho::PLATFORM_MACOS,
                    "built for another Apple platform"
                );
                dylib.minimum_macos = Some(version(b.minos.get(endian)));
            }
            LoadCommandVariant::VersionMin(v) => {
                assert_eq!(
                    command.cmd(),
                    macho::LC_VERSION_MIN_MACOSX,
                    "built for another Apple platform"
                );
                dylib.minimum_macos = Some(version(v.version.get(endian)));
            }
            _ => {}
        }
    }
    dylib
}

fn check_dylib(what: &str, bytes: &[u8], reference: &BTreeSet<String>) -> MachODylib {
    let file = object::File::parse(bytes).unwrap();
    assert_exports_all(what, &file, reference);
    let dylib = read_dylib(bytes);
    assert_eq!(dylib.loads, [LIB_SYSTEM], "{what} loads more than libSystem");
    assert_eq!(
        dylib.install_name.as_deref(),
        Some(INSTALL_NAME),
        "{what}: install name"
    );
    let oldest = match dylib.architecture {
        Architecture::X86_64 => (10, 12),
        Architecture::Aarch64 => (11, 0),
        other => panic!("{what}: a dylib for {other:?}"),
    };
    assert_eq!(
        dylib.minimum_macos,
        Some(oldest),
        "{what}: the oldest macOS it loads on"
    );
    dylib
}

#[test]
fn macos_dylibs_are_checked_from_their_files_as_macos_cannot_run_here() {
    let reference = reference_exports();
    let Some(universal) = packed(FMI2, "binaries/darwin64/TireLag.dylib") else {
        return;
    };
    let thin = [
        (Architecture::X86_64, "binaries/x86_64-darwin/TireLag.dylib"),
        (Architecture::Aarch64, "binaries/aarch64-darwin/TireLag.dylib"),
    ];
    let fat = MachOFatFile32::parse(&*universal).expect("darwin64 holds one universal (fat) dylib");
    let mut architectures = Vec::new();
    for arch in fat.arches() {
        use object::read::macho::FatArch;
        let slice = arch.data(&*universal).unwrap();
        let dylib = check_dylib("darwin64/TireLag.dylib", slice, &reference);
        architectures.push(dylib.architecture);
        let (_, name) = thin.iter().find(|(a, _)| *a == dylib.architecture).unwrap();
        let alone = packed(FMI3, name).expect("the FMI 3.0 FMU carries both macOS architectures");
        assert!(
            alone == slice,
            "{name} differs from its slice of the universal dylib"
        );
    }
    architectures.sort_by_key(|a| format!("{a:?}"));
    assert_eq!(architectures, [Architecture::Aarch64, Architecture::X86_64]);
    for (_, name) in thin {
        check_dylib(name, &packed(FMI3, name).unwrap(), &reference);
    }
}
