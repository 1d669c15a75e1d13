"""What the two FMUs carry beside their model description and binaries (docs/specification.md 1b).

For target/fmu/TireLag.fmu (FMI 2.0) and target/fmu/fmi3/TireLag.fmu (FMI 3.0):
- the documentation (documentation/_main.html, documentation/index.html) has every section
  docs/specification.md 1b asks for, and its variable tables name every variable of the packed model
  description (read here by fmpy, not by the packer's own reader) with its unit,
  causality, variability, value reference and start value, and the selectors' items;
- its fmpy example runs against the FMU and prints what the page says; its C master
  compiles against the packed library and prints what the page says;
- the platforms it lists are exactly the binaries in the archive;
- the icon (model.png; FMI 3.0 terminalsAndIcons/icon.png) is a valid 256 x 256 RGBA PNG
  (every chunk's CRC, the image data's size and filters) that shows a tire;
- FMI 3.0 terminalsAndIcons.xml is valid against fmpy's fmi3TerminalsAndIcons.xsd and its
  one terminal holds the hub inputs and the force and moment outputs of the model
  description, with their causalities;
- `fmpy validate` finds no problem;
- the archive is reproducible: packing its own contents again (twice) gives the same bytes,
  and every entry has the fixed time stamp and permissions;
- scripts/pack_fmu.py lists exactly the platforms it packs and refuses bad arguments.
"""

from __future__ import annotations

import platform
import shutil
import struct
import subprocess
import sys
import zipfile
import zlib
from html.parser import HTMLParser
from pathlib import Path

import pytest

import friction_reference as fr
import reference as ref
from conftest import REPO

sys.path.insert(0, str(REPO / "scripts"))
import pack_fmu  # noqa: E402

FMUS = {"2": REPO / "target" / "fmu" / "TireLag.fmu", "3": REPO / "target" / "fmu" / "fmi3" / "TireLag.fmu"}
DOCUMENTATION = {"2": "documentation/_main.html", "3": "documentation/index.html"}
ICONS = {"2": ["model.png"], "3": ["terminalsAndIcons/icon.png", "icons/icon.png"]}
TERMINALS = ["terminalsAndIcons/terminalsAndIcons.xml", "icons/terminalsAndIcons.xml"]
FOLDERS = {"2": {"linux64": "so", "win64": "dll", "darwin64": "dylib"},
           "3": {"x86_64-linux": "so", "aarch64-linux": "so", "x86_64-windows": "dll",
                 "x86_64-darwin": "dylib", "aarch64-darwin": "dylib"}}
SECTIONS = ["what", "signs", "models", "friction", "choose", "variables", "fmpy", "modelica", "c",
            "platforms", "licence"]
HUB_INPUTS = ["vx", "vy", "steerRate", "vsx", "Fz"]
HUB_OUTPUTS = ["Fx", "Fy", "Mz", "My"]
ICON_SIZE = 256


# --------------------------------------------------------------------------- helpers

class Page(HTMLParser):
    """The parts of a documentation page the tests read: the tables by class (rows of cell
    texts, the first row the header), the text of elements whose class starts with
    "example", the ids, and the text of each h2 section."""

    def __init__(self, text: str):
        super().__init__(convert_charrefs=True)
        self.tables: dict[str, list[tuple[bool, list[str]]]] = {}  # (header row?, cell texts)
        self.examples: dict[str, list[str]] = {}
        self.ids: list[str] = []
        self.sections: dict[str, str] = {}
        self._table = self._row = self._cell = self._example = self._section = None
        self._header = False
        self.open: list[str] = []          # the elements open at this point
        self.mismatched: list[str] = []    # end tags that close no open element
        self.resources: list[str] = []     # what the page would load: src, <link>, <script>
        self.feed(text)
        self.close()

    VOID = {"meta", "img", "br", "hr", "link", "input", "col", "area", "base", "source", "wbr"}

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag not in self.VOID:
            self.open.append(tag)
        if tag in ("script", "link", "iframe", "object", "embed") or "src" in attrs:
            self.resources.append(f"<{tag}> {attrs.get('src') or attrs.get('href') or ''}"[:80])
        if "id" in attrs:
            self.ids.append(attrs["id"])
        if tag == "h2":
            self._section = attrs.get("id")
            self.sections[self._section] = ""
        cls = attrs.get("class") or ""
        if tag == "table" and cls:
            self._table = cls
            self.tables.setdefault(cls, [])
        elif tag == "tr" and self._table:
            self._row, self._header = [], False
        elif tag in ("td", "th") and self._row is not None:
            self._cell = ""
            self._header = tag == "th"
        if cls.startswith("example"):
            self._example = (tag, cls)
            self.examples.setdefault(cls, []).append("")

    def handle_endtag(self, tag):
        if self.open and self.open[-1] == tag:
            self.open.pop()
        else:
            self.mismatched.append(f"</{tag}> inside {self.open[-3:]}")
        if self._example and tag == self._example[0]:
            self._example = None
        if tag in ("td", "th") and self._cell is not None:
            self._row.append(self._cell.strip())
            self._cell = None
        elif tag == "tr" and self._row is not None:
            self.tables[self._table].append((self._header, self._row))
            self._row = None
        elif tag == "table":
            self._table = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data
        if self._example:
            self.examples[self._example[1]][-1] += data
        if self._section:
            self.sections[self._section] += data

    def rows(self, cls):
        """The rows of every table of this class, as dicts keyed by the header."""
        rows, header = [], None
        for is_header, row in self.tables.get(cls, []):
            if is_header:
                header = row
            else:
                assert header and len(row) == len(header), (cls, header, row)
                rows.append(dict(zip(header, row)))
        return rows


def png_chunks(data: bytes):
    """(type, payload) of every chunk, checking the signature, lengths and CRCs."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG signature"
    chunks, pos = [], 8
    while pos < len(data):
        assert pos + 12 <= len(data), "truncated chunk"
        length, kind = struct.unpack_from(">I4s", data, pos)
        payload = data[pos + 8:pos + 8 + length]
        assert len(payload) == length, f"chunk {kind} truncated"
        (crc,) = struct.unpack_from(">I", data, pos + 8 + length)
        assert crc == zlib.crc32(kind + payload) & 0xFFFFFFFF, f"bad CRC of chunk {kind}"
        chunks.append((kind, payload))
        pos += 12 + length
    assert chunks[0][0] == b"IHDR" and chunks[-1][0] == b"IEND", [c[0] for c in chunks]
    return chunks


def decode_png(data: bytes):
    """(width, height, rows of RGBA bytes) of an 8-bit RGBA, non-interlaced PNG."""
    chunks = png_chunks(data)
    width, height, depth, colour, compression, filtering, interlace = struct.unpack(">IIBBBBB", chunks[0][1])
    assert (depth, colour, compression, filtering, interlace) == (8, 6, 0, 0, 0), "not 8-bit RGBA"
    raw = zlib.decompress(b"".join(p for k, p in chunks if k == b"IDAT"))
    stride = width * 4
    assert len(raw) == height * (1 + stride), "image data of the wrong size"
    rows, previous = [], bytearray(stride)
    for y in range(height):
        kind, line = raw[y * (1 + stride)], bytearray(raw[y * (1 + stride) + 1:(y + 1) * (1 + stride)])
        assert kind <= 4, f"unknown filter {kind} in row {y}"
        for i in range(stride):
            a = line[i - 4] if i >= 4 else 0
            b = previous[i]
            c = previous[i - 4] if i >= 4 else 0
            if kind == 1:
                line[i] = (line[i] + a) & 0xFF
            elif kind == 2:
                line[i] = (line[i] + b) & 0xFF
            elif kind == 3:
                line[i] = (line[i] + (a + b) // 2) & 0xFF
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 0xFF
        rows.append(bytes(line))
        previous = line
    return width, height, rows


class Fmu:
    def __init__(self, version: str, path: Path | None = None):
        self.version = version
        self.path = path or FMUS[version]
        if not self.path.is_file():
            pytest.fail(f"FMU not found: {self.path} (build it with ./scripts/build-fmu)")
        self.zip = zipfile.ZipFile(self.path)
        self.names = self.zip.namelist()
        from fmpy import read_model_description

        self.md = read_model_description(str(self.path))
        self.page = Page(self.read(DOCUMENTATION[version]).decode("utf-8"))

    def read(self, name):
        assert name in self.names, f"{self.path.name} (FMI {self.version}.0) has no {name}: {self.names}"
        return self.zip.read(name)

    def binaries(self):
        """{folder: file name} of binaries/<folder>/<file>."""
        found = {}
        for name in self.names:
            parts = name.split("/")
            if parts[0] == "binaries" and len(parts) == 3 and parts[2]:
                assert parts[1] not in found, f"two files in binaries/{parts[1]}/"
                found[parts[1]] = parts[2]
        return found


@pytest.fixture(scope="module", params=["2", "3"], ids=["fmi2", "fmi3"])
def fmu(request):
    return Fmu(request.param)


@pytest.fixture(scope="module")
def fmu3():
    return Fmu("3")


def pack(argv):
    """Runs pack_fmu.py's main in this process; returns (exit code, stderr text)."""
    import contextlib
    import io

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        try:
            pack_fmu.main([str(a) for a in argv])
            code = 0
        except SystemExit as e:
            code = e.code
    return code, err.getvalue()


def repack(fmu: Fmu, out_dir: Path, name="TireLag.fmu", extra_binaries=(), only_linux_x86_64=False):
    """Packs the FMU again from its own model description and binaries (or its Linux
    x86_64 binary alone), plus any extra --binary arguments; returns the new archive's
    path."""
    src = out_dir / "src"
    (src / "fmi3").mkdir(parents=True, exist_ok=True)
    description = src / "fmi3" / "modelDescription.xml"
    description.write_bytes(fmu.read("modelDescription.xml"))
    argv = ["--fmi", fmu.version, "--description", description]
    for folder, file in fmu.binaries().items():
        if only_linux_x86_64 and folder not in ("linux64", "x86_64-linux"):
            continue
        path = src / folder / file
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(fmu.read(f"binaries/{folder}/{file}"))
        argv += ["--binary", f"{folder}={path}"]
    for folder, path in extra_binaries:
        argv += ["--binary", f"{folder}={path}"]
    output = out_dir / name
    code, err = pack(argv + [output])
    assert code == 0, err
    return output


# --------------------------------------------------------------------------- documentation

def test_documentation_has_every_section(fmu):
    page = fmu.page
    assert not page.mismatched and page.open == [], (page.mismatched, page.open)
    # self-contained: nothing to load but the embedded icon, no script
    assert all(r.startswith("<img> data:image/png;base64,") for r in page.resources), page.resources
    for section in SECTIONS:
        assert section in page.sections, f"no section {section!r} in {DOCUMENTATION[fmu.version]}"
        assert len(page.sections[section].split()) > 20, f"section {section!r} is nearly empty"
    text = " ".join(page.sections.values())
    for name in list(ref.MODELS) + list(fr.FRICTION_LAWS):
        assert name in page.sections["models"] + page.sections["friction"] + page.sections["choose"], name
    assert "Brush" in page.sections["friction"] and "default" in page.sections["friction"]
    assert "positive alpha gives a positive Fy" in text
    assert "MIT" in page.sections["licence"]
    assert "Permission is hereby granted" in page.sections["licence"]
    # the interface names of this FMI version only
    other = {"2": "fmi3", "3": "fmi2"}[fmu.version]
    own = f"fmi{fmu.version}"
    assert own + "DoStep" in page.examples["example-c"][0]
    assert other + "DoStep" not in " ".join(page.examples["example-c"])
    # the packed licence file is the repository's
    assert fmu.read("documentation/LICENSE.txt") == (REPO / "LICENSE").read_bytes()


def test_documentation_names_every_variable_with_its_unit(fmu):
    rows = fmu.page.rows("variables")
    by_name = {}
    for row in rows:
        assert row["name"] not in by_name, f"{row['name']} listed twice"
        by_name[row["name"]] = row
    variables = {v.name: v for v in fmu.md.modelVariables}
    assert set(by_name) == set(variables), (set(variables) ^ set(by_name))
    for name, v in variables.items():
        row = by_name[name]
        unit = v.unit or (getattr(v.declaredType, "unit", None) if v.declaredType else None) or ""
        assert row["unit"] == unit, (name, row["unit"], unit)
        assert row["causality"] == v.causality, name
        assert row["variability"] == v.variability, name
        assert row["value reference"] == str(v.valueReference), name
        assert row["type"].split()[0] == v.type, (name, row["type"], v.type)
        if v.start:
            assert row["start"] == v.start, (name, row["start"], v.start)
        for bound in ("min", "max"):
            if getattr(v, bound, None) is not None:
                assert row[bound] == str(getattr(v, bound)), (name, bound)
    # the selectors with their items
    for name, items in (("tireModel", ref.MODELS), ("friction", fr.FRICTION_LAWS)):
        for item, value in items.items():
            assert f"{value} = {item}" in by_name[name]["description"], (name, item)


def test_documentation_lists_exactly_the_packed_platforms(fmu):
    binaries = fmu.binaries()
    assert binaries, "no binary in the archive"
    identifier = (fmu.md.coSimulation or fmu.md.modelExchange).modelIdentifier
    for folder, file in binaries.items():
        assert folder in FOLDERS[fmu.version], f"binaries/{folder}/ is no FMI {fmu.version}.0 folder"
        assert file == f"{identifier}.{FOLDERS[fmu.version][folder]}", (folder, file)
    listed = [row["folder"] for row in fmu.page.rows("platforms")]
    assert sorted(listed) == sorted(f"binaries/{f}/" for f in binaries), (listed, binaries)
    platforms = " ".join(fmu.page.sections["platforms"].split())
    aarch64_note = "Linux on aarch64 (arm64): FMI 2.0 has no binary folder for it" in platforms
    assert aarch64_note == (fmu.version == "2"), "the FMI 2.0 page sends Linux aarch64 users to the FMI 3.0 FMU"
    if aarch64_note:
        assert "Take the FMI 3.0 TireLag FMU there" in platforms


def test_fmpy_example_runs_and_prints_what_the_page_says(fmu, tmp_path):
    code = fmu.page.examples["example-fmpy"][0]
    expected = fmu.page.examples["example-fmpy-output"][0].strip()
    shutil.copy(fmu.path, tmp_path / "TireLag.fmu")
    (tmp_path / "example.py").write_text(code)
    run = subprocess.run([sys.executable, "example.py"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == expected, (run.stdout, run.stderr)
    assert "Warning" not in run.stdout + run.stderr, run.stdout + run.stderr


@pytest.mark.skipif(platform.system() != "Linux" or platform.machine() != "x86_64" or not shutil.which("cc"),
                    reason="the page's build line is for Linux x86_64 with a C compiler")
def test_c_example_compiles_runs_and_prints_what_the_page_says(fmu, tmp_path):
    import fmpy

    headers = Path(fmpy.__file__).parent / "c-code"
    fmu.zip.extractall(tmp_path / "TireLag")
    (tmp_path / "master.c").write_text(fmu.page.examples["example-c"][0])
    build = fmu.page.examples["example-c-build"][0].strip().replace("fmi-headers", str(headers))
    built = subprocess.run(build + " -Wall -Werror", shell=True, cwd=tmp_path, capture_output=True,
                           text=True, timeout=120)
    assert built.returncode == 0, built.stderr
    run = subprocess.run([str(tmp_path / "master")], cwd="/", capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.strip() == fmu.page.examples["example-c-output"][0].strip()


# --------------------------------------------------------------------------- icon

def test_icon_is_a_256_pixel_rgba_png_of_a_tire(fmu):
    icons = [fmu.read(name) for name in ICONS[fmu.version]]
    assert all(icon == icons[0] for icon in icons), "the icon's copies differ"
    width, height, rows = decode_png(icons[0])
    assert (width, height) == (ICON_SIZE, ICON_SIZE)

    def pixel(fx, fy):
        """RGBA at (fx, fy) in [-1, 1], y up."""
        x = min(width - 1, int((fx + 1) / 2 * width))
        y = min(height - 1, int((1 - fy) / 2 * height))
        return rows[y][4 * x:4 * x + 4]

    for corner in ((-0.99, -0.99), (0.99, 0.99), (-0.99, 0.99), (0.99, -0.99)):
        assert pixel(*corner)[3] == 0, "the background is transparent"
    ring = [pixel(0.82 * c, 0.82 * s) for c, s in ((1, 0), (0, 1), (-1, 0), (0, -1), (0.6, 0.8))]
    assert all(p[3] == 255 and max(p[:3]) < 60 for p in ring), f"a dark tread ring: {ring}"
    hub = pixel(0.0, 0.19)
    assert hub[3] == 255 and 90 < hub[0] < 200, f"a grey hub: {hub}"
    middle_row_alpha = rows[height // 2][3::4]
    assert any(0 < a < 255 for a in middle_row_alpha), "anti-aliased edges"


# --------------------------------------------------------------------------- terminals

def test_terminals_are_valid_and_group_the_hub(fmu3):
    from lxml import etree
    import fmpy

    texts = [fmu3.read(name) for name in TERMINALS]
    assert all(t == texts[0] for t in texts), "the copies of terminalsAndIcons.xml differ"
    xsd = Path(fmpy.__file__).parent / "schema" / "fmi3" / "fmi3TerminalsAndIcons.xsd"
    schema = etree.XMLSchema(etree.parse(str(xsd)))
    doc = etree.fromstring(texts[0])
    assert schema.validate(doc), str(schema.error_log)
    assert doc.get("fmiVersion") == fmu3.md.fmiVersion

    variables = {v.name: v for v in fmu3.md.modelVariables}
    terminals = doc.findall("Terminals/Terminal")
    assert len(terminals) == 1
    members = terminals[0].findall("TerminalMemberVariable")
    names = [m.get("variableName") for m in members]
    assert names == HUB_INPUTS + HUB_OUTPUTS, names
    member_names = [m.get("memberName") for m in members]
    assert len(set(member_names)) == len(member_names) and all(member_names)
    for m in members:
        v = variables[m.get("variableName")]
        assert v.causality == ("input" if v.name in HUB_INPUTS else "output"), v.name
        assert m.get("variableKind") == "signal"
    # the hub's inputs are all the inputs; its outputs all the force and moment outputs
    assert set(HUB_INPUTS) == {v.name for v in variables.values() if v.causality == "input"}
    assert set(HUB_OUTPUTS) == {v.name for v in variables.values()
                                if v.causality == "output" and v.unit in ("N", "N.m")}
    # the icon covers the coordinate system
    icon = doc.find("GraphicalRepresentation/Icon")
    system = doc.find("GraphicalRepresentation/CoordinateSystem")
    assert [icon.get(k) for k in ("x1", "y1", "x2", "y2")] == [system.get(k) for k in ("x1", "y1", "x2", "y2")]


# --------------------------------------------------------------------------- validation

def test_fmpy_validate_is_clean(fmu):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu.path)) == []
    run = subprocess.run([sys.executable, "-m", "fmpy", "validate", str(fmu.path)], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0 and "No problems found" in run.stdout, run.stdout + run.stderr


# --------------------------------------------------------------------------- reproducibility

def test_archive_entries_are_fixed(fmu):
    infos = fmu.zip.infolist()
    assert [i.filename for i in infos] == sorted(i.filename for i in infos), "entries in name order"
    for info in infos:
        assert info.date_time == (1980, 1, 1, 0, 0, 0), info.filename
        assert info.create_system == 3, info.filename
        assert info.compress_type == zipfile.ZIP_DEFLATED, info.filename
        mode = info.external_attr >> 16
        assert mode == (0o755 if info.filename.startswith("binaries/") else 0o644), (info.filename, oct(mode))


def test_packing_again_gives_the_same_bytes(fmu, tmp_path):
    """Packed twice from the FMU's own contents: the same bytes both times, and the same as
    the FMU itself (so the shipped documentation, icon and terminals are the current ones)."""
    first = repack(fmu, tmp_path / "a").read_bytes()
    second = repack(fmu, tmp_path / "b").read_bytes()
    assert first == second, "packing twice gave different archives"
    assert first == fmu.path.read_bytes(), (
        f"{fmu.path} differs from what scripts/pack_fmu.py makes of its contents: rebuild it "
        "with ./scripts/build-fmu")


# --------------------------------------------------------------------------- pack_fmu.py

def fake_library(kind: str) -> bytes:
    """The first bytes of a library of this kind: enough for pack_fmu.py's format check."""
    if kind == "aarch64-elf":
        return b"\x7fELF\x02\x01\x01" + bytes(11) + struct.pack("<H", 183) + bytes(64)
    if kind == "x86_64-pe":
        return b"MZ" + bytes(0x3A) + struct.pack("<I", 0x40) + b"PE\0\0" + struct.pack("<H", 0x8664) + bytes(64)
    if kind == "arm64-macho":
        return b"\xcf\xfa\xed\xfe" + struct.pack("<I", 0x0100000C) + bytes(64)
    if kind == "universal-macho":
        return (b"\xca\xfe\xba\xbe" + struct.pack(">I", 2) + struct.pack(">IIIII", 0x01000007, 3, 4096, 64, 12)
                + struct.pack(">IIIII", 0x0100000C, 0, 8192, 64, 14) + bytes(64))
    raise ValueError(kind)


@pytest.mark.parametrize("version, extra", [
    ("2", {"win64": "x86_64-pe", "darwin64": "universal-macho"}),
    ("3", {"aarch64-linux": "aarch64-elf", "x86_64-windows": "x86_64-pe", "aarch64-darwin": "arm64-macho"}),
])
def test_the_page_lists_the_platforms_packed(version, extra, tmp_path):
    """A scratch archive (never shipped) with stand-ins for the other platforms' libraries:
    each packed under its folder's name and extension, and the page lists exactly them."""
    fmu = Fmu(version)
    paths = []
    for folder, kind in extra.items():
        path = tmp_path / f"{folder}.bin"
        path.write_bytes(fake_library(kind))
        paths.append((folder, path))
    scratch = Fmu(version, repack(fmu, tmp_path, "scratch.fmu", paths, only_linux_x86_64=True))
    folders = {"2": {"linux64"}, "3": {"x86_64-linux"}}[version] | set(extra)
    assert set(scratch.binaries()) == folders
    for folder in extra:
        assert scratch.read(f"binaries/{folder}/TireLag.{FOLDERS[version][folder]}") == fake_library(extra[folder])
    assert sorted(row["folder"] for row in scratch.page.rows("platforms")) == sorted(f"binaries/{f}/" for f in folders)


@pytest.fixture(scope="module")
def library():
    path = REPO / "target" / "fmu" / "TireLag.so"
    if not path.is_file():
        pytest.fail(f"no {path} (build it with ./scripts/build-fmu)")
    return path


def fmi3_description():
    """The FMI 3.0 model description, as packed."""
    return zipfile.ZipFile(FMUS["3"]).read("modelDescription.xml")


@pytest.mark.parametrize("case", ["unknown folder 2", "unknown folder 3", "missing file", "no binary",
                                  "wrong format", "wrong cpu", "thin darwin64", "fmi3 without description",
                                  "wrong version", "twice"])
def test_pack_refuses_bad_arguments(case, library, tmp_path):
    description3 = tmp_path / "fmi3" / "modelDescription.xml"
    description3.parent.mkdir()
    description3.write_bytes(fmi3_description())
    macho = tmp_path / "thin.dylib"
    macho.write_bytes(fake_library("arm64-macho"))
    argv, message = {
        "unknown folder 2": (["--fmi", "2", "--binary", f"x86_64-linux={library}"],
                             "'x86_64-linux' is not an FMI 2.0 binary folder; FMI 2.0 folders: linux64, win64, darwin64"),
        "unknown folder 3": (["--fmi", "3", "--description", description3, "--binary", f"linux64={library}"],
                             "'linux64' is not an FMI 3.0 binary folder"),
        "missing file": (["--fmi", "2", "--binary", f"linux64={tmp_path / 'nothing.so'}"], "no file at"),
        "no binary": (["--fmi", "2"], "give at least one --binary"),
        "wrong format": (["--fmi", "2", "--binary", f"linux64={library}", "--binary", f"win64={library}"],
                         "not a Windows PE file"),
        "wrong cpu": (["--fmi", "3", "--description", description3, "--binary", f"aarch64-linux={library}"],
                      "an ELF file for x86_64, not aarch64"),
        "thin darwin64": (["--fmi", "2", "--binary", f"darwin64={macho}"], "universal (fat)"),
        "fmi3 without description": (["--fmi", "3", "--binary", f"x86_64-linux={library}"], "FMI 3.0 takes --description"),
        "wrong version": (["--fmi", "3", "--description", REPO / "modelDescription" / "modelDescription.xml",
                           "--binary", f"x86_64-linux={library}"], "is FMI 2.0"),
        "twice": (["--fmi", "2", "--binary", f"linux64={library}", "--binary", f"linux64={library}"],
                  "given twice"),
    }[case]
    output = tmp_path / "out.fmu"
    code, err = pack(argv + [output])
    assert code != 0 and message in err, err
    assert not output.exists() and not output.with_suffix(".fmu.partial").exists()
