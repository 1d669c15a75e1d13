"""Packs an FMU archive reproducibly: fixed entry order, timestamps and permissions.

usage: pack_fmu.py --fmi 2 [--description MD.xml] --binary linux64=PATH
                   [--binary win64=PATH] [--binary darwin64=PATH] OUTPUT.fmu
       pack_fmu.py --fmi 3 --description OUT_DIR/fmi3/modelDescription.xml
                   --binary x86_64-linux=PATH [--binary x86_64-windows=PATH]
                   [--binary aarch64-linux=PATH] [--binary x86_64-darwin=PATH]
                   [--binary aarch64-darwin=PATH] OUTPUT.fmu

FMI 2.0 takes modelDescription/modelDescription.xml unless --description says otherwise;
FMI 3.0 takes the model description build.rs generated from it. Each --binary FOLDER=PATH
packs PATH as binaries/FOLDER/<modelIdentifier>.<so|dll|dylib> (at least one; the folders
each FMI version names, each once, each file checked to be a library for its folder's
operating system and CPU).

Beside them the archive gets, made at pack time from the model description being packed
(scripts/fmu_docs.py, scripts/tire_icon.py):
- documentation/_main.html (FMI 2.0) or documentation/index.html (FMI 3.0): the prose of
  modelDescription/documentation.html.in with the variable tables and the platforms packed;
- documentation/LICENSE.txt: the repository's LICENSE;
- the icon, a tire: model.png (FMI 2.0) or terminalsAndIcons/icon.png (FMI 3.0);
- FMI 3.0: terminalsAndIcons/terminalsAndIcons.xml, the wheel hub as one terminal.

Same inputs, same bytes: entries in name order, every time stamp 1980-01-01 00:00,
permissions 0755 for binaries and 0644 for the rest, deflate level 9, made on Unix.
"""

from __future__ import annotations

import argparse
import pathlib
import struct
import sys
import zipfile

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

import fmu_docs  # noqa: E402
import tire_icon  # noqa: E402

ROOT = fmu_docs.ROOT
FIXED_TIME = (1980, 1, 1, 0, 0, 0)
DEFAULT_DESCRIPTION = {"2": ROOT / "modelDescription" / "modelDescription.xml"}

# FMI 3.0's folder for icons and terminals is terminalsAndIcons/ (FMI 3.0, 3.0.1 and 3.0.2:
# section 2.5, "Structure of the ZIP file", and section 2.4, "Terminals and Icons"); importers
# look there. The same two files are packed in icons/ too, the folder of a draft of the
# standard that earlier versions of the contract named (docs/specification.md 1b).
FMI3_ICON_FOLDERS = ("terminalsAndIcons", "icons")

# What a library for each folder starts with: the object format and the CPU.
ELF_MACHINE = {"x86_64": 62, "aarch64": 183}
PE_MACHINE = {"x86_64": 0x8664}
MACHO_CPU = {"x86_64": 0x01000007, "arm64": 0x0100000C}
EXPECTED = {
    "linux64": ("elf", ("x86_64",)), "win64": ("pe", ("x86_64",)),
    "darwin64": ("macho-fat", ("x86_64", "arm64")),
    "x86_64-linux": ("elf", ("x86_64",)), "aarch64-linux": ("elf", ("aarch64",)),
    "x86_64-windows": ("pe", ("x86_64",)),
    "x86_64-darwin": ("macho", ("x86_64",)), "aarch64-darwin": ("macho", ("arm64",)),
}
assert set(EXPECTED) == {f for folders in fmu_docs.PLATFORMS.values() for f in folders}


def library_problem(folder: str, data: bytes) -> str | None:
    """Why `data` is not a library for `folder`, or None if it is."""
    kind, cpus = EXPECTED[folder]
    if kind == "elf":
        if data[:4] != b"\x7fELF" or len(data) < 20 or data[4] != 2 or data[5] != 1:
            return "not a 64-bit little-endian ELF file"
        machine = struct.unpack_from("<H", data, 18)[0]
        if machine != ELF_MACHINE[cpus[0]]:
            names = {v: k for k, v in ELF_MACHINE.items()}
            return f"an ELF file for {names.get(machine, f'machine {machine}')}, not {cpus[0]}"
        return None
    if kind == "pe":
        if data[:2] != b"MZ" or len(data) < 0x40:
            return "not a Windows PE file (no MZ header)"
        pe = struct.unpack_from("<I", data, 0x3C)[0]
        if data[pe:pe + 4] != b"PE\0\0":
            return "not a Windows PE file (no PE signature)"
        machine = struct.unpack_from("<H", data, pe + 4)[0]
        if machine != PE_MACHINE[cpus[0]]:
            return f"a PE file for machine {machine:#x}, not {cpus[0]}"
        return None
    # Mach-O: thin (64-bit, little-endian) or universal (fat, big-endian header)
    magic = data[:4]
    if magic in (b"\xca\xfe\xba\xbe", b"\xca\xfe\xba\xbf"):
        count = struct.unpack_from(">I", data, 4)[0]
        entry = 20 if magic == b"\xca\xfe\xba\xbe" else 32
        found = {struct.unpack_from(">I", data, 8 + k * entry)[0] for k in range(min(count, 16))}
    elif magic == b"\xcf\xfa\xed\xfe":
        if kind == "macho-fat":
            return "a thin Mach-O file; darwin64 takes one universal (fat) library with x86_64 and arm64"
        found = {struct.unpack_from("<I", data, 4)[0]}
    else:
        return "not a Mach-O file"
    missing = [cpu for cpu in cpus if MACHO_CPU[cpu] not in found]
    if missing:
        return f"a Mach-O file without {' and '.join(missing)}"
    return None


def entries(md: fmu_docs.ModelDescription, description: bytes, binaries: dict[str, bytes]):
    """(archive name, bytes) of every file of the FMU."""
    version = md.fmi_version
    icon = tire_icon.tire_png()
    yield "modelDescription.xml", description
    for folder, data in binaries.items():
        ext = fmu_docs.PLATFORMS[version][folder][2]
        yield f"binaries/{folder}/{md.model_identifier}.{ext}", data
    yield "documentation/LICENSE.txt", fmu_docs.LICENSE.read_bytes()
    yield fmu_docs.DOCUMENTATION[version], fmu_docs.documentation_html(md, sorted(binaries), icon)
    if version == "2":
        yield fmu_docs.ICON["2"], icon
    else:
        terminals = fmu_docs.terminals_and_icons_xml(md)
        for folder in FMI3_ICON_FOLDERS:
            yield f"{folder}/icon.png", icon
            yield f"{folder}/terminalsAndIcons.xml", terminals


def write_fmu(output: pathlib.Path, files) -> None:
    output.parent.mkdir(parents=True, exist_ok=True)
    partial = output.with_suffix(".fmu.partial")
    with zipfile.ZipFile(partial, "w", compression=zipfile.ZIP_DEFLATED) as fmu:
        for name, data in sorted(files):
            info = zipfile.ZipInfo(name, date_time=FIXED_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o755 if name.startswith("binaries/") else 0o644) << 16
            info.create_system = 3  # Unix, so the permissions above are read back
            fmu.writestr(info, data, compresslevel=9)
    partial.replace(output)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     usage=__doc__.split("\n\n")[1].removeprefix("usage: "))
    parser.add_argument("--fmi", choices=sorted(fmu_docs.PLATFORMS), required=True)
    parser.add_argument("--description", type=pathlib.Path,
                        help="the model description (FMI 2.0 default: modelDescription/modelDescription.xml)")
    parser.add_argument("--binary", action="append", default=[], metavar="FOLDER=PATH",
                        help="a library to pack as binaries/FOLDER/ (repeat for each platform)")
    parser.add_argument("output", type=pathlib.Path)
    args = parser.parse_args(argv)

    folders = fmu_docs.PLATFORMS[args.fmi]
    description = args.description or DEFAULT_DESCRIPTION.get(args.fmi)
    if description is None:
        parser.error("FMI 3.0 takes --description: the model description build.rs generates "
                     "(OUT_DIR/fmi3/modelDescription.xml)")
    if not description.is_file():
        parser.error(f"no model description at {description}")
    try:
        md = fmu_docs.read_model_description(description)
    except (ValueError, SyntaxError) as e:
        parser.error(str(e))
    if md.fmi_version != args.fmi:
        parser.error(f"--fmi {args.fmi} takes an FMI {args.fmi}.0 model description; "
                     f"{description} is FMI {md.fmi_version}.0")

    if not args.binary:
        parser.error("no binary: give at least one --binary FOLDER=PATH "
                     f"(FMI {args.fmi}.0 folders: {', '.join(folders)})")
    binaries: dict[str, bytes] = {}
    for spec in args.binary:
        folder, sep, path = spec.partition("=")
        if not sep or not folder or not path:
            parser.error(f"--binary {spec!r}: write FOLDER=PATH, e.g. {next(iter(folders))}=target/fmu/TireLag.so")
        if folder not in folders:
            parser.error(f"--binary {spec!r}: {folder!r} is not an FMI {args.fmi}.0 binary folder; "
                         f"FMI {args.fmi}.0 folders: {', '.join(folders)}")
        if folder in binaries:
            parser.error(f"--binary {spec!r}: binaries/{folder}/ is given twice")
        file = pathlib.Path(path)
        if not file.is_file():
            parser.error(f"--binary {spec!r}: no file at {file}")
        data = file.read_bytes()
        problem = library_problem(folder, data)
        if problem:
            parser.error(f"--binary {spec!r}: {file} is {problem}, so not a library for binaries/{folder}/")
        binaries[folder] = data

    write_fmu(args.output, entries(md, description.read_bytes(), binaries))


if __name__ == "__main__":
    main()
