"""Packs an FMU archive reproducibly: fixed entry order, timestamps and permissions.

usage: pack_fmu.py --fmi 2 BINARY OUTPUT.fmu
       pack_fmu.py --fmi 3 --description MODEL_DESCRIPTION.xml BINARY OUTPUT.fmu

FMI 2.0 takes modelDescription/modelDescription.xml and binaries/linux64/; FMI 3.0 takes
the model description build.rs generated from it and binaries/x86_64-linux/.
"""

import argparse
import pathlib
import zipfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIXED_TIME = (1980, 1, 1, 0, 0, 0)
PLATFORM = {"2": "linux64", "3": "x86_64-linux"}


def entries(version: str, description: pathlib.Path, binary: pathlib.Path):
    yield "modelDescription.xml", description.read_bytes()
    yield f"binaries/{PLATFORM[version]}/TireLag.so", binary.read_bytes()
    yield "documentation/LICENSE.txt", (ROOT / "LICENSE").read_bytes()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmi", choices=sorted(PLATFORM), required=True)
    parser.add_argument("--description", type=pathlib.Path,
                        default=ROOT / "modelDescription" / "modelDescription.xml")
    parser.add_argument("binary", type=pathlib.Path)
    parser.add_argument("output", type=pathlib.Path)
    args = parser.parse_args()
    if args.fmi == "3" and args.description.parent.name != "fmi3":
        parser.error("FMI 3.0 takes the model description build.rs generates (OUT_DIR/fmi3/)")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    partial = args.output.with_suffix(".fmu.partial")
    with zipfile.ZipFile(partial, "w", compression=zipfile.ZIP_DEFLATED) as fmu:
        for name, data in sorted(entries(args.fmi, args.description, args.binary)):
            info = zipfile.ZipInfo(name, date_time=FIXED_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o755 if name.endswith(".so") else 0o644) << 16
            info.create_system = 3  # Unix, so the permissions above are read back
            fmu.writestr(info, data, compresslevel=9)
    partial.replace(args.output)


if __name__ == "__main__":
    main()
