"""MuJoCo scenes (MJCF) rewritten before Drake's MJCF parser reads them:

- its `<include>`s inlined, as MuJoCo inserts an included file's children
  in the include's place (a file that includes itself is one line: Drake
  follows it until its stack overflows);
- a plane geom becomes a placeholder box marked as a plane (`MARK`), which
  `world_files` turns into the ground (facing up) or a slab: Drake would
  make it a half space, and a half space among many geometries crashes
  SceneGraph (Drake #19263, docs/big_scenes.md);
- a geom that collides with nothing (`contype` and `conaffinity` 0, written
  or from its default class: MuJoCo Menagerie's visual meshes) is left out,
  and so is every mesh asset no geom left uses, so that a visual mesh that
  is missing or in a format Drake does not read never blocks loading;
- the folder it reads meshes from (`<compiler meshdir assetdir>`) made
  absolute, since Drake reads the rewritten text, not the file.
"""

import os
import xml.etree.ElementTree as ET

from mfi_drake.world.model_files import read_xml

MAX_DEPTH = 32  # includes nested deeper are a loop
_FOLDERS = ("assetdir", "meshdir", "texturedir")


def _inline(root: ET.Element, origins: dict, folder: str, chain: list[str]) -> None:
    """Each `<include file>` under `root` replaced by the included file's
    children, recursively; MuJoCo resolves includes against the main
    file's folder (`folder`). A missing file is left for Drake to name."""
    for parent in list(root.iter()):
        for k, include in reversed(list(enumerate(parent))):
            if include.tag != "include":
                continue
            target = os.path.normpath(os.path.join(folder, include.get("file", "")))
            if not os.path.isfile(target):
                include.set("file", target)
                continue
            if target in chain or len(chain) >= MAX_DEPTH:
                raise ValueError(f"{origins[include]}: {target} includes itself")
            inner, more = read_xml(target)
            origins.update(more)
            _inline(inner, origins, folder, [*chain, target])
            parent[k : k + 1] = list(inner)


def _defaults(root: ET.Element) -> dict[str, dict]:
    """Each default class's geom attributes, inherited from the classes it
    nests in (the top class is "main")."""
    classes: dict[str, dict] = {}

    def walk(default: ET.Element, inherited: dict) -> None:
        attributes = dict(inherited)
        for geom in default.findall("geom"):
            attributes.update(geom.attrib)
        classes[default.get("class", "main")] = attributes
        for inner in default.findall("default"):
            walk(inner, attributes)

    for default in root.findall("default"):
        walk(default, classes.get("main", {}))
    return classes


def _geoms(element: ET.Element, childclass: str):
    """(parent, geom, its class) of every geom under `element`, the class
    its own, else the nearest enclosing `childclass`."""
    for child in list(element):
        if child.tag == "geom":
            yield element, child, child.get("class", childclass)
        elif child.tag in ("body", "frame", "worldbody", "replicate"):
            yield from _geoms(child, child.get("childclass", childclass))


def _absolute_folders(root: ET.Element, folder: str) -> None:
    """The folder meshes are read from, absolute, in one `<compiler>`:
    MuJoCo reads a mesh from `meshdir`, else `assetdir`, else the main
    file's folder, each relative to that folder."""
    said: dict[str, str] = {}
    for compiler in root.findall("compiler"):
        said.update(
            {k: compiler.attrib.pop(k) for k in _FOLDERS if k in compiler.attrib}
        )
    assets = os.path.join(folder, said.get("assetdir", ""))
    compiler = root.find("compiler")
    if compiler is None:
        compiler = ET.Element("compiler")
        root.insert(0, compiler)
    # Textures are not read: Drake's parser warns at a `texturedir`.
    meshes = said.get("meshdir")
    compiler.set("meshdir", os.path.join(assets, meshes) if meshes else assets)


def rewrite_mjcf(
    path: str, root: ET.Element, origins: dict
) -> tuple[str, list[tuple[list[float], str]], int]:
    """The MJCF file `path` (parsed: `root`, `origins`) rewritten as the
    module says: (its text, each plane's normal in its geom's frame and
    "file:line", how many geoms that collide with nothing were left out).
    Raises ValueError, one line naming the file and line."""
    folder = os.path.dirname(os.path.abspath(path))
    _inline(root, origins, folder, [os.path.abspath(path)])
    classes = _defaults(root)
    planes, visual, used = [], 0, set()
    for worldbody in root.findall("worldbody"):
        for parent, geom, kind in list(_geoms(worldbody, "main")):
            inherited = classes.get(kind, classes.get("main", {}))

            def get(key: str, default: str, geom=geom, inherited=inherited) -> str:
                return geom.get(key, inherited.get(key, default))

            if get("contype", "1").strip() == "0" == get("conaffinity", "1").strip():
                parent.remove(geom)
                visual += 1
                continue
            if get("type", "sphere") == "plane":
                name = geom.get("name", "plane")
                geom.attrib.update(
                    type="box",
                    size="0.5 0.5 0.5",
                    name=f"__mfi_plane_{len(planes)}__{name}",
                )
                planes.append(([0.0, 0.0, 1.0], origins.get(geom, path)))
            if get("mesh", ""):
                used.add(get("mesh", ""))
    for asset in root.findall("asset"):
        for mesh in asset.findall("mesh"):
            name = (
                mesh.get("name")
                or os.path.splitext(os.path.basename(mesh.get("file", "")))[0]
            )
            if name not in used:
                asset.remove(mesh)
    _absolute_folders(root, folder)
    return ET.tostring(root, encoding="unicode"), planes, visual
