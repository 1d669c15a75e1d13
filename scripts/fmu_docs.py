"""What pack_fmu.py writes into an FMU beside the model description and the binaries.

- read_model_description(path): the variables, types, units and interfaces of an FMI 2.0
  or FMI 3.0 modelDescription.xml (xml.etree; the one source of truth for all of them).
- documentation_html(md, platforms): documentation/_main.html (FMI 2.0) or
  documentation/index.html (FMI 3.0): the prose of modelDescription/documentation.html.in
  with the variable tables of `md` and the table of the platforms packed.
- terminals_and_icons_xml(md): FMI 3.0 terminalsAndIcons.xml: the wheel hub as one terminal
  (the hub inputs and the force and moment outputs), from the variables of `md`.

Everything here is a pure function of its inputs: the same inputs give the same bytes.
"""

from __future__ import annotations

import base64
import html
import pathlib
import re
import string
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

ROOT = pathlib.Path(__file__).resolve().parent.parent
TEMPLATE = ROOT / "modelDescription" / "documentation.html.in"
LICENSE = ROOT / "LICENSE"

# Binary folders by FMI version: folder -> (operating system, CPU, library extension).
PLATFORMS = {
    "2": {
        "linux64": ("Linux (glibc 2.17 or newer)", "x86_64", "so"),
        "win64": ("Windows 7 or newer", "x86_64", "dll"),
        "darwin64": ("macOS 11 or newer", "x86_64 and arm64 (Apple silicon) in one universal library", "dylib"),
    },
    "3": {
        "x86_64-linux": ("Linux (glibc 2.17 or newer)", "x86_64", "so"),
        "aarch64-linux": ("Linux (glibc 2.17 or newer)", "aarch64 (arm64)", "so"),
        "x86_64-windows": ("Windows 7 or newer", "x86_64", "dll"),
        "x86_64-darwin": ("macOS 11 or newer", "x86_64 (Intel)", "dylib"),
        "aarch64-darwin": ("macOS 11 or newer", "aarch64 (Apple silicon)", "dylib"),
    },
}

# The documentation's entry point and the icon, by FMI version (FMI 2.0 section 2.3,
# FMI 3.0 section 2.5).
DOCUMENTATION = {"2": "documentation/_main.html", "3": "documentation/index.html"}
ICON = {"2": "model.png", "3": "terminalsAndIcons/icon.png"}

# Causality groups of the variable tables, in order.
GROUPS = [
    ("input", "Inputs", "Set them before every step (or, in Model Exchange, before every evaluation)."),
    ("output", "Outputs", "Read them after every step; they always belong to the current states and the inputs set last."),
    ("parameter", "Parameters", ""),  # the note says how to set them (their variability)
    ("calculatedParameter", "Calculated parameters", ""),
    ("local", "Model Exchange states, derivatives and event indicators",
     "What a Model Exchange solver integrates and watches; readable in Co-Simulation too."),
    ("independent", "Independent variable", ""),
]

TIME_ATTRIBUTES = ("startTime", "stopTime", "stepSize")  # of DefaultExperiment, in seconds
FORCE_UNITS = ("N", "N.m")  # outputs of the hub terminal: the forces and moments on the hub


@dataclass
class Item:
    name: str
    value: str
    description: str = ""


@dataclass
class Variable:
    name: str
    value_reference: int
    causality: str
    variability: str
    type: str                       # Real, Integer, String, ... (FMI 2.0); Float64, Int64, Enumeration, ... (FMI 3.0)
    description: str = ""
    unit: str = ""
    display_unit: str = ""
    start: str | None = None
    min: str | None = None
    max: str | None = None
    declared_type: str = ""
    items: list[Item] = field(default_factory=list)


@dataclass
class ModelDescription:
    fmi_version: str                # "2" or "3"
    model_name: str
    model_identifier: str
    token: str                      # the GUID (FMI 2.0) or instantiationToken (FMI 3.0)
    description: str
    interfaces: list[str]
    default_experiment: dict[str, str]
    variables: list[Variable]

    def variable(self, name: str) -> Variable:
        return next(v for v in self.variables if v.name == name)


def _items_from_description(text: str) -> list[Item]:
    """Items written as '1 = RLT, 2 = DDT' in a description (an FMI 2.0 Integer type)."""
    return [Item(name, value) for value, name in re.findall(r"(-?\d+) = (\w+)", text or "")]


def read_model_description(path: pathlib.Path | str) -> ModelDescription:
    root = ET.parse(path).getroot()
    if root.tag != "fmiModelDescription":
        raise ValueError(f"{path}: not an FMI model description (root element {root.tag})")
    version = root.get("fmiVersion", "")
    major = version.split(".")[0]
    if major not in PLATFORMS:
        raise ValueError(f"{path}: fmiVersion {version!r} is neither 2.0 nor 3.0")

    interfaces, identifiers = [], set()
    for tag, label in (("CoSimulation", "Co-Simulation"), ("ModelExchange", "Model Exchange"),
                       ("ScheduledExecution", "Scheduled Execution")):
        element = root.find(tag)
        if element is not None:
            interfaces.append(label)
            identifiers.add(element.get("modelIdentifier"))
    if len(identifiers) != 1 or None in identifiers:
        raise ValueError(f"{path}: expected one modelIdentifier over the interfaces, found {sorted(map(str, identifiers))}")

    # Declared types: their unit and, for enumerations, their items.
    types: dict[str, tuple[str, str, list[Item]]] = {}
    for simple in root.iterfind("TypeDefinitions/*"):
        name = simple.get("name")
        if major == "2":
            body = next(iter(simple), None)
            unit = body.get("unit", "") if body is not None else ""
            items = [Item(i.get("name"), i.get("value"), i.get("description", ""))
                     for i in (body.iterfind("Item") if body is not None else [])]
        else:
            unit = simple.get("unit", "")
            items = [Item(i.get("name"), i.get("value"), i.get("description", "")) for i in simple.iterfind("Item")]
        types[name] = (unit, simple.get("description", ""), items)
    if major == "2":
        # TireLag's FMI 2.0 selectors are Integers (docs/specification.md 3); their item
        # names stand in a vendor annotation (what build.rs makes the FMI 3.0 Enumerations
        # of) or, failing that, in the type's description.
        for enum in root.iterfind("VendorAnnotations/Tool/Fmi3/EnumerationType"):
            name = enum.get("name")
            if name in types and not types[name][2]:
                types[name] = (types[name][0], types[name][1],
                               [Item(i.get("name"), i.get("value"), i.get("description", ""))
                                for i in enum.iterfind("Item")])
        for name, (unit, description, items) in list(types.items()):
            if not items:
                types[name] = (unit, description, _items_from_description(description))

    variables = []
    if major == "2":
        for sv in root.iterfind("ModelVariables/ScalarVariable"):
            body = next(iter(sv))
            declared = body.get("declaredType", "")
            unit, _, items = types.get(declared, ("", "", []))
            variables.append(Variable(
                name=sv.get("name"), value_reference=int(sv.get("valueReference")),
                causality=sv.get("causality", "local"), variability=sv.get("variability", "continuous"),
                type=body.tag, description=sv.get("description", ""),
                unit=body.get("unit", unit), display_unit=body.get("displayUnit", ""),
                start=body.get("start"), min=body.get("min"), max=body.get("max"),
                declared_type=declared, items=items))
    else:
        for v in root.find("ModelVariables"):
            declared = v.get("declaredType", "")
            unit, _, items = types.get(declared, ("", "", []))
            start = v.get("start")
            if start is None and v.find("Start") is not None:
                start = v.find("Start").get("value")
            variables.append(Variable(
                name=v.get("name"), value_reference=int(v.get("valueReference")),
                causality=v.get("causality", "local"), variability=v.get("variability", "continuous"),
                type=v.tag, description=v.get("description", ""),
                unit=v.get("unit", unit), display_unit=v.get("displayUnit", ""),
                start=start, min=v.get("min"), max=v.get("max"),
                declared_type=declared, items=items))

    experiment = root.find("DefaultExperiment")
    return ModelDescription(
        fmi_version=major, model_name=root.get("modelName", ""), model_identifier=identifiers.pop(),
        token=root.get("guid") if major == "2" else root.get("instantiationToken"),
        description=root.get("description", ""), interfaces=interfaces,
        default_experiment=dict(experiment.attrib) if experiment is not None else {},
        variables=variables)


# --------------------------------------------------------------------------- documentation

def _cell(text, cls=""):
    attr = f' class="{cls}"' if cls else ""
    return f"<td{attr}>{text}</td>"


def _value(text):
    if text is None:
        return ""
    return "<code>\"\"</code>" if text == "" else f"<code>{html.escape(text)}</code>"


def _description(v: Variable) -> str:
    text = html.escape(v.description, quote=False)
    if v.display_unit:
        text += ("" if not text or text.endswith(".") else ".") + f" Displayed in {html.escape(v.display_unit)}."
    if v.items:
        rows = "".join(f"<li><code>{html.escape(i.value)}</code> = <b>{html.escape(i.name)}</b>"
                       + (f": {html.escape(i.description)}" if i.description else "") + "</li>"
                       for i in v.items)
        kind = "Items" if v.type == "Enumeration" else f"Values (declared type {html.escape(v.declared_type)})"
        text += f'<ul class="items"><li class="head">{kind}:</li>{rows}</ul>'
    return text


def variable_tables(md: ModelDescription) -> str:
    """One table per causality, every variable of the model description in it."""
    out = []
    known = {g[0] for g in GROUPS}
    groups = GROUPS + [(c, f"Causality {c}", "") for c in sorted({v.causality for v in md.variables} - known)]
    for causality, title, note in groups:
        members = [v for v in md.variables if v.causality == causality]
        if not members:
            continue
        if causality == "parameter":
            fixed = all(v.variability == "fixed" for v in members)
            note = ("All fixed: set them before initialisation ends." if fixed else
                    "Set fixed ones before initialisation ends; tunable ones may change between steps.")
        out.append(f'<h3 id="variables-{causality}">{html.escape(title)} ({len(members)})</h3>')
        if note:
            out.append(f"<p>{note}</p>")
        out.append('<table class="variables">\n<tr><th>name</th><th>value reference</th><th>type</th>'
                   "<th>causality</th><th>variability</th><th>unit</th><th>start</th><th>min</th>"
                   "<th>max</th><th>description</th></tr>")
        for v in members:
            type_text = html.escape(v.type) + (f" ({html.escape(v.declared_type)})" if v.declared_type else "")
            out.append("<tr>" + "".join([
                _cell(f"<code>{html.escape(v.name)}</code>", "name"),
                _cell(str(v.value_reference), "num"),
                _cell(type_text),
                _cell(html.escape(v.causality)),
                _cell(html.escape(v.variability)),
                _cell(html.escape(v.unit), "unit"),
                _cell(_value(v.start), "num"),
                _cell(_value(v.min), "num"),
                _cell(_value(v.max), "num"),
                _cell(_description(v)),
            ]) + "</tr>")
        out.append("</table>")
    return "\n".join(out)


def platform_table(version: str, folders: list[str], model_identifier: str) -> str:
    rows = ['<table class="platforms">',
            "<tr><th>folder</th><th>operating system</th><th>CPU</th><th>library</th></tr>"]
    for folder in sorted(folders):
        system, cpu, ext = PLATFORMS[version][folder]
        rows.append("<tr>" + "".join([
            _cell(f"<code>binaries/{folder}/</code>", "folder"), _cell(html.escape(system)),
            _cell(html.escape(cpu)), _cell(f"<code>{model_identifier}.{ext}</code>")]) + "</tr>")
    rows.append("</table>")
    return "\n".join(rows)


def _select_version(text: str, version: str) -> str:
    """Keeps <!--fmiN-->...<!--/fmiN--> blocks of this version, drops the others."""
    def keep(match):
        return match.group(2) if match.group(1) == version else ""
    text = re.sub(r"<!--fmi([23])-->(.*?)<!--/fmi\1-->", keep, text, flags=re.DOTALL)
    if "<!--fmi" in text or "<!--/fmi" in text:
        raise ValueError(f"{TEMPLATE}: unbalanced <!--fmiN--> markers")
    return text


def documentation_html(md: ModelDescription, folders: list[str], icon_png: bytes,
                       template: pathlib.Path = TEMPLATE, license_path: pathlib.Path = LICENSE) -> bytes:
    """The documentation of an FMU with this model description, these binary folders and
    this icon (embedded, so the page needs no other file)."""
    version = md.fmi_version
    fields = {
        "icon_data_uri": "data:image/png;base64," + base64.b64encode(icon_png).decode("ascii"),
        "fmi_version": f"{version}.0",
        "model_name": html.escape(md.model_name),
        "model_identifier": html.escape(md.model_identifier),
        "model_description": html.escape(md.description),
        "token": html.escape(md.token),
        "interfaces": " and ".join(md.interfaces),
        "default_experiment": ", ".join(f"{k} {html.escape(v)}{' s' if k in TIME_ATTRIBUTES else ''}"
                                        for k, v in md.default_experiment.items()),
        "variable_count": str(len(md.variables)),
        "variable_tables": variable_tables(md),
        "platform_table": platform_table(version, folders, html.escape(md.model_identifier)),
        "icon": ICON[version],
        "license": html.escape(license_path.read_text(encoding="utf-8").strip()),
    }
    for v in md.variables:
        if v.name.isidentifier():
            fields[f"vr_{v.name}"] = str(v.value_reference)
            fields[f"start_{v.name}"] = html.escape(v.start or "")
    text = re.sub(r"<!--#.*?-->\n?", "", template.read_text(encoding="utf-8"), flags=re.DOTALL)  # notes on the template
    text = _select_version(text, version)
    return string.Template(text).substitute(fields).encode("utf-8")


# --------------------------------------------------------------------------- terminals

def hub_terminal_members(md: ModelDescription) -> list[Variable]:
    """The wheel hub's variables: every input, then the force and moment outputs."""
    inputs = [v for v in md.variables if v.causality == "input"]
    forces = [v for v in md.variables if v.causality == "output" and v.unit in FORCE_UNITS]
    if not inputs or not forces:
        raise ValueError("the model description has no hub inputs or no force outputs for the hub terminal")
    return inputs + forces


def terminals_and_icons_xml(md: ModelDescription) -> bytes:
    """FMI 3.0 terminalsAndIcons.xml (fmi3TerminalsAndIcons.xsd): the icon over the default
    coordinate system, and the wheel hub as one terminal: matchingRule bus (members matched
    by name, a partial match allowed), every member a signal."""
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiTerminalsAndIcons fmiVersion="{md.fmi_version}.0">',
        "  <GraphicalRepresentation>",
        '    <CoordinateSystem x1="-100" y1="-100" x2="100" y2="100" suggestedScalingFactorTo_mm="0.1"/>',
        '    <Icon x1="-100" y1="-100" x2="100" y2="100"/>',
        "  </GraphicalRepresentation>",
        "  <Terminals>",
        '    <Terminal name="hub" matchingRule="bus" terminalKind="_TireLag_WheelHub"'
        ' description="The wheel hub: its velocities in the wheel frame, the steer rate, the slip'
        ' velocity and the normal load in; the forces and moments the tire applies to the hub out">',
    ]
    for v in hub_terminal_members(md):
        lines.append(f'      <TerminalMemberVariable variableName="{html.escape(v.name)}"'
                     f' memberName="{html.escape(v.name)}" variableKind="signal"/>')
    lines += ["    </Terminal>", "  </Terminals>", "</fmiTerminalsAndIcons>", ""]
    return "\n".join(lines).encode("utf-8")
