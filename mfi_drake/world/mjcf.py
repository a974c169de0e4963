"""MuJoCo scenes (MJCF) rewritten before Drake's MJCF parser reads them:

- its `<include>`s inlined, as MuJoCo inserts an included file's children
  in the include's place (a file that includes itself is one line: Drake
  follows it until its stack overflows);
- a plane geom becomes a placeholder box marked as a plane (`MARK`), which
  `world_files` turns into the ground (facing up) or a slab: Drake would
  make it a half space, and a half space among many geometries crashes
  SceneGraph (Drake #19263, docs/big_scenes.md);
- a geom that collides with nothing (`contype` and `conaffinity` 0, written
  or from its default class: MuJoCo Menagerie's visual meshes) is left out;
- joints, and the sections of the dynamics (actuators, tendons, equality
  constraints, sensors, keyframes, contact pairs), are left out: the scene
  is flown still, each body where the file (and MuJoCo's qpos0) puts it;
- a mesh geom becomes a placeholder box marked as a mesh, its file (from
  `<compiler meshdir assetdir>`, as MuJoCo reads it) and scale (the
  asset's, else its default class's) listed: `world_files` flies its
  convex hull, which is what MuJoCo collides with, read by this project's
  mesh reader (STL, OBJ and the others: Drake's MJCF parser reads OBJ
  only). So every mesh asset is left out, and a visual mesh that is missing
  or in a format nobody reads never blocks loading.
"""

import os
import xml.etree.ElementTree as ET

from mfi_drake.world.model_files import read_xml

MAX_DEPTH = 32  # includes nested deeper are a loop
_FOLDERS = ("assetdir", "meshdir", "texturedir")
_JOINTS = ("joint", "freejoint")  # in a body, or a <default>'s
# The sections that drive, couple, measure or pose the joints, pair geoms
# for contact or set the simulator and viewer: none is read by a flight
# (Drake warned of most of the settings, dozens of lines a file).
_DYNAMICS = ("actuator", "tendon", "equality", "sensor", "keyframe", "contact")
_DYNAMICS += ("option", "size", "statistic", "visual", "custom", "extension")


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


def _defaults(root: ET.Element, tag: str) -> dict[str, dict]:
    """Each default class's attributes of element `tag` (geom, mesh),
    inherited from the classes it nests in (the top class is "main")."""
    classes: dict[str, dict] = {}

    def walk(default: ET.Element, inherited: dict) -> None:
        attributes = dict(inherited)
        for element in default.findall(tag):
            attributes.update(element.attrib)
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


def _mesh_folder(root: ET.Element, folder: str) -> str:
    """The folder MuJoCo reads meshes from: `meshdir`, else `assetdir`,
    else the main file's folder, each relative to that folder; the
    `<compiler>` folders are removed (Drake reads no mesh and no texture
    of the rewritten text)."""
    said: dict[str, str] = {}
    for compiler in root.findall("compiler"):
        said.update(
            {k: compiler.attrib.pop(k) for k in _FOLDERS if k in compiler.attrib}
        )
    assets = os.path.join(folder, said.get("assetdir", ""))
    meshes = said.get("meshdir")
    return os.path.join(assets, meshes) if meshes else assets


def _mesh_assets(root: ET.Element, folder: str) -> dict[str, tuple[str, list]]:
    """Each mesh asset by name (its file's name less the suffix where it has
    none): (its file, its scale per axis), every mesh asset removed."""
    classes = _defaults(root, "mesh")
    meshes = {}
    for asset in root.findall("asset"):
        for mesh in asset.findall("mesh"):
            inherited = classes.get(mesh.get("class", "main"), {})
            file = mesh.get("file", inherited.get("file", ""))
            name = mesh.get("name") or os.path.splitext(os.path.basename(file))[0]
            scale = mesh.get("scale", inherited.get("scale", "1 1 1")).split()
            meshes[name] = (os.path.join(folder, file) if file else "", scale)
            asset.remove(mesh)
    return meshes


def rewrite_mjcf(
    path: str, root: ET.Element, origins: dict
) -> tuple[str, list, list, int, int]:
    """The MJCF file `path` (parsed: `root`, `origins`) rewritten as the
    module says: (its text, each plane's normal in its geom's frame and
    "file:line", each mesh's (file, scale per axis, "file:line"), how many
    geoms that collide with nothing were left out, how many joints).
    Raises ValueError, one line naming the file and line."""
    folder = os.path.dirname(os.path.abspath(path))
    _inline(root, origins, folder, [os.path.abspath(path)])
    if not root.get("model", "").strip():  # Drake needs a name; MuJoCo not
        root.set("model", os.path.splitext(os.path.basename(path))[0])
    moved = _stilled(root)
    classes = _defaults(root, "geom")
    assets = _mesh_assets(root, _mesh_folder(root, folder))
    planes, meshes, visual = [], [], 0
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
            elif get("type", "sphere") == "mesh":
                meshes.append(_mesh(geom, get("mesh", ""), assets, origins, path))
                geom.attrib.pop("mesh", None)
                geom.attrib.update(
                    type="box",
                    size="0.5 0.5 0.5",
                    name=f"__mfi_mesh_{len(meshes) - 1}__{geom.get('name', 'mesh')}",
                )
    return ET.tostring(root, encoding="unicode"), planes, meshes, visual, moved


def _stilled(root: ET.Element) -> int:
    """Leaves out what moves the scene, which a flight among its geoms never
    reads: joints (each body then sits where the file puts it, which is
    where MuJoCo's qpos0 does) and the sections of the dynamics (actuators,
    tendons, equality constraints, sensors, keyframes, contact pairs, the
    simulator's settings). Drake's parser refused scenes for them: an
    actuator of a joint it had not made (PyBullet's MPL hand), a joint type
    only PyBullet reads ("fixed"). Returns how many joints were left out."""
    for section in [c for c in root if c.tag in _DYNAMICS]:
        root.remove(section)
    joints = 0
    for parent in list(root.iter()):
        for child in [c for c in parent if c.tag in _JOINTS]:
            joints += parent.tag == "body"  # a <default>'s is no joint
            parent.remove(child)
    return joints


def _mesh(geom: ET.Element, name: str, assets: dict, origins: dict, path: str) -> tuple:
    """(file, scale per axis, "file:line") of a mesh geom's asset `name`."""
    where = origins.get(geom, path)
    if name not in assets:
        raise ValueError(f"{where}: a mesh geom names no mesh asset ({name!r})")
    file, scale = assets[name]
    if not file:
        raise ValueError(
            f"{where}: mesh {name!r} has no file (inline vertices are not read)"
        )
    try:
        numbers = [float(x) for x in scale]
    except ValueError:
        numbers = []
    if len(numbers) != 3:
        raise ValueError(
            f"{where}: mesh {name!r}: scale {' '.join(scale)!r} is not 3 numbers"
        )
    return file, numbers, where
