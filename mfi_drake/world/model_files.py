"""The files a world names: XML read with each element's line (for errors
that name it), and the folders `model://`, `package://` and Fuel URIs
name, found as Gazebo and ROS find them (`sdformat` resolves with these),
and `Prepared`, what `sdformat.prepare` makes of a world file for Drake."""

import codecs
import os
import re
import xml.etree.ElementTree as ET
import xml.parsers.expat
from bisect import bisect_right
from collections import Counter
from dataclasses import dataclass, field
from urllib.parse import unquote

MODEL_ENV = ("GAZEBO_MODEL_PATH", "GZ_SIM_RESOURCE_PATH", "IGN_GAZEBO_RESOURCE_PATH")


def read_xml(path: str, text: str | None = None) -> tuple[ET.Element, dict]:
    """The XML file `path` (or `text`, named `path`) as elements, and each
    element's "file:line". Raises ValueError naming the line."""
    origins: dict[ET.Element, str] = {}
    stack: list[ET.Element] = []
    root: list[ET.Element] = []
    parser = xml.parsers.expat.ParserCreate()

    def start(tag: str, attrs: dict) -> None:
        element = ET.Element(tag, attrs)
        origins[element] = f"{path}:{parser.CurrentLineNumber}"
        (stack[-1].append if stack else root.append)(element)
        stack.append(element)

    def text_of(data: str) -> None:
        if stack:  # only a leaf's text is read: children's tails are not
            stack[-1].text = (stack[-1].text or "") + data

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    parser.CharacterDataHandler = text_of
    parser.EntityDeclHandler = _no_entities
    try:
        if text is None:
            with open(path, "rb") as f:
                text = f.read()
        parser.Parse(_lenient(text), True)
    except xml.parsers.expat.ExpatError as e:
        line = getattr(e, "lineno", parser.CurrentLineNumber)
        raise ValueError(f"{path}:{line}: not well-formed XML: {e}") from None
    except (OSError, RecursionError) as e:
        raise ValueError(f"{path}: not readable: {e}") from None
    return root[0], origins


def _lenient(text: str | bytes) -> bytes:
    """`text` with "--" inside comments written "- " and an XML declaration
    after a comment or a blank line moved to the start (XML forbids both;
    Gazebo's parser, TinyXML2, reads them, and Gazebo's own example worlds
    and models hold them), the lines unchanged: the declaration is one."""
    data = text.encode() if isinstance(text, str) else text
    declaration = re.search(rb"<\?xml[^>]*\?>", data)
    if declaration and declaration.start() > 0:
        before = data[: declaration.start()]
        bom = codecs.BOM_UTF8 if before.startswith(codecs.BOM_UTF8) else b""
        rest = before[len(bom) :] + data[declaration.end() :]
        # Kept, not dropped: it may name the file's encoding.
        data = bom + declaration[0] + re.sub(rb"<\?xml[^>]*\?>", b"", rest)
    return re.sub(
        rb"<!--(.*?)-->",
        lambda m: b"<!--" + m[1].replace(b"--", b"- ") + b"-->",
        data,
        flags=re.S,
    )


def _no_entities(name, *_) -> None:
    """Entity declarations are refused: expanded, a few lines can make
    gigabytes (an XML bomb)."""
    raise xml.parsers.expat.ExpatError(f"entity {name!r} declared: not read")


def env_folders(names: tuple[str, ...]) -> list[str]:
    return [f for n in names for f in os.environ.get(n, "").split(":") if f]


# The Fuel models worlds written for Gazebo Sim include most (Gazebo's own
# examples write them inline; turtlebot3_gazebo's worlds include the Ground
# Plane in 7 files, the Sun in 3), by (owner, name) in lower case:
# stand-ins written here (mfi_drake/models/fuel, each what Fuel's holds: a
# light; an upward plane at z = 0), read where no Fuel cache holds the
# model (a machine without Gazebo, or one that never went online).
FUEL_STAND_INS = {
    ("openrobotics", "sun"): "sun",
    ("openrobotics", "ground plane"): "ground_plane",
}
STAND_INS = os.path.join(os.path.dirname(os.path.dirname(__file__)), "models", "fuel")


def fuel_folders(uri: str, where: str) -> tuple[str, str, list[str], str]:
    """A Fuel URI (https://HOST/1.0/OWNER/models/NAME[/VERSION][/files/PATH]):
    the model's name, the PATH in it, its folders in Gazebo's Fuel caches
    (GZ_FUEL_CACHE_PATH, ~/.gz/fuel, ~/.ignition/fuel), and the folder of
    this project's stand-in for it ("" for none: `FUEL_STAND_INS`)."""
    parts = [unquote(p) for p in uri.split("://", 1)[1].split("/")]
    if len(parts) < 5 or parts[3].lower() != "models":
        raise ValueError(f"{where}: {uri}: not a Fuel model's URI")
    host, owner, name, rest = parts[0], parts[2], parts[4], parts[5:]
    inner = "/".join(rest[rest.index("files") + 1 :]) if "files" in rest else ""
    roots = [os.environ.get("GZ_FUEL_CACHE_PATH", ""), "~/.gz/fuel", "~/.ignition/fuel"]
    cached = [
        os.path.join(os.path.expanduser(r), host, owner.lower(), "models", name.lower())
        for r in roots
        if r
    ]
    stand_in = FUEL_STAND_INS.get((owner.lower(), name.lower()))
    return name, inner, cached, os.path.join(STAND_INS, stand_in) if stand_in else ""


def newest_version(folder: str) -> str:
    """The highest numbered version folder of a cached Fuel model."""
    versions = (
        [v for v in os.listdir(folder) if v.isdigit()] if os.path.isdir(folder) else []
    )
    return os.path.join(folder, max(versions, key=int)) if versions else ""


def find_package(name: str, folders: list[str]) -> str:
    """A folder named `name`, or holding a package.xml naming it, at most
    three levels under one of `folders` (ROS_PACKAGE_PATH's roots)."""
    for base in folders:
        if os.path.basename(os.path.normpath(base)) == name:
            return base
        for top, dirs, files in os.walk(base):
            if os.path.basename(top) == name and top != base:
                return top
            if "package.xml" in files:
                try:
                    root, _ = read_xml(os.path.join(top, "package.xml"))
                except ValueError:
                    continue
                if (root.findtext("name") or "").strip() == name:
                    return top
            if top.count(os.sep) - base.count(os.sep) >= 3:
                dirs.clear()
    return ""


def model_file(folder: str, where: str) -> str:
    """The SDFormat file of a Gazebo model folder: the one its model.config
    names (of several <sdf>, the highest version), else model.sdf."""
    config = os.path.join(folder, "model.config")
    if os.path.isfile(config):
        root, _ = read_xml(config)
        named = [
            (e.get("version", "0"), (e.text or "").strip()) for e in root.iter("sdf")
        ]
        named = [(v, f) for v, f in named if f]
        if named:
            version = max(named, key=lambda vf: _version(vf[0]))
            return os.path.join(folder, version[1])
    if os.path.isfile(os.path.join(folder, "model.sdf")):
        return os.path.join(folder, "model.sdf")
    raise ValueError(
        f"{where}: model folder {folder} holds no model.config or model.sdf"
    )


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(x) for x in re.findall(r"\d+", text))


_SHOWN = "plugin light actor sensor visual gui joint population"
SHOWN = tuple(_SHOWN.split())  # in the one line (population: models not read)


@dataclass
class Prepared:
    """A world file rewritten for Drake: `texts` in format `kind` ("sdf",
    "urdf"), each parsed apart (a world's models in parts: Drake's parse
    time grows as their number squared), the collision meshes, planes,
    terrains and extrusions its placeholders number, what was read past,
    and where each element of each text came from."""

    texts: list[str] = field(default_factory=list)
    kind: str = "sdf"
    # Each placeholder's mesh: its file, scale and the "file:line" naming it;
    # each plane's: its normal (in its collision's frame) and "file:line".
    meshes: list[tuple[str, list[float], str]] = field(default_factory=list)
    planes: list[tuple[list[float], str]] = field(default_factory=list)
    # Each terrain's: its image, <size>, <pos> and "file:line".
    heightmaps: list[tuple[str, list[float], list[float], str]] = field(
        default_factory=list
    )
    # Each extrusion's: its polylines' points and heights, and "file:line".
    polylines: list[tuple[list, str]] = field(default_factory=list)
    # Each mesh's convex pieces once decomposed, by `decomposition.mesh_key`
    # (`world_files` fills it).
    pieces: dict = field(default_factory=dict)
    read_past: Counter = field(default_factory=Counter)
    stand_ins: Counter = field(default_factory=Counter)  # Fuel models, by name
    unknown: Counter = field(default_factory=Counter)
    starts: list[list[int]] = field(default_factory=list)  # each element's line
    sources: list[list[str]] = field(default_factory=list)  # its "file:line"

    def source(self, part: int, line: int) -> str:
        """The "file:line" of what is on line `line` of `texts[part]`."""
        k = bisect_right(self.starts[part], line) - 1
        return self.sources[part][max(k, 0)]

    def summary(self) -> str:
        """What was read past, in one line ("" for nothing worth saying)."""
        counts = [(k, self.read_past[k]) for k in SHOWN if self.read_past[k]]
        said = ", ".join(f"{n} {k}{'s' if n > 1 else ''}" for k, n in counts)
        if self.unknown:
            names = ", ".join(f"{k} ({n}×)" for k, n in sorted(self.unknown.items()))
            said += ("; " if said else "") + f"what SDFormat does not define: {names}"
        said = f"read past {said}" if said else ""
        if self.stand_ins:
            names = ", ".join(repr(k) for k in sorted(self.stand_ins))
            said += (
                f"{'; ' if said else ''}Fuel's {names} not downloaded: "
                "mfi_drake's stand-in read (Gazebo's shape)"
            )
        return said
