"""Packs the FMU archive reproducibly: fixed entry order, timestamps and permissions.

usage: pack_fmu.py BINARY OUTPUT.fmu
"""

import pathlib
import sys
import zipfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIXED_TIME = (1980, 1, 1, 0, 0, 0)


def entries(binary: pathlib.Path):
    yield "modelDescription.xml", (ROOT / "modelDescription" / "modelDescription.xml").read_bytes()
    yield "binaries/linux64/TireLag.so", binary.read_bytes()
    yield "documentation/LICENSE.txt", (ROOT / "LICENSE").read_bytes()


def main() -> None:
    binary, output = map(pathlib.Path, sys.argv[1:3])
    output.parent.mkdir(parents=True, exist_ok=True)
    partial = output.with_suffix(".fmu.partial")
    with zipfile.ZipFile(partial, "w", compression=zipfile.ZIP_DEFLATED) as fmu:
        for name, data in sorted(entries(binary)):
            info = zipfile.ZipInfo(name, date_time=FIXED_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o755 if name.endswith(".so") else 0o644) << 16
            info.create_system = 3  # Unix, so the permissions above are read back
            fmu.writestr(info, data, compresslevel=9)
    partial.replace(output)


if __name__ == "__main__":
    main()
