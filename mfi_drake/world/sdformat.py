"""World files as their tools ship them, made into what Drake's Parser reads.

A Gazebo world (.world, .sdf; Classic or Sim) or a URDF is read with line
numbers and rewritten before Drake sees it: what flies is a world's
collision geometry at its pose, so only that is kept.

- `<include>` of `model://NAME`, `package://PKG/...`, a file or a folder
  is replaced by the model it names, as Gazebo does: a model folder's
  model.config names its SDFormat file (the highest version), else
  model.sdf; the include's <name>, <pose> and <static> override the
  model's own. Includes nest; a relative URI resolves against the folder
  of the file that holds it. `model://` is searched in `model_paths`, then
  GAZEBO_MODEL_PATH, GZ_SIM_RESOURCE_PATH, IGN_GAZEBO_RESOURCE_PATH, then
  beside the file that names it; `package://` in `model_paths`, then
  ROS_PACKAGE_PATH; a Fuel URL as a folder of the model's name, else in
  Gazebo's Fuel cache (`model_files`).
- Visuals, sensors, plugins, lights, actors, GUI, physics, inertials,
  joints... are read past (counted), as is every element and attribute
  SDFormat does not define (Bullet's `concave="yes"`): they never block
  a load, and a URI only a visual uses is never resolved.
- Every model is static, its links where its file (or its world's
  `<state>`, applied here as Gazebo applies it) puts them; a URDF's joints
  are fixed at zero. Inertia never matters.
- A collision mesh (any format), plane, heightmap or polyline is replaced
  by a placeholder box whose name `sdf_rules.MARK` numbers it: Drake reads
  no mesh file, and `world_files` decomposes the mesh itself
  (`Prepared.meshes`), makes a terrain's columns (`world.terrain`) and an
  extrusion's prisms (`world.extrusions`). A plane is no half space in
  Drake's SceneGraph: among thousands of geometries, one crashes its
  broadphase (FCL) as they are registered.

Errors are one line naming the file and line of their cause (ValueError).
"""

import os
import xml.etree.ElementTree as ET
from collections import Counter

from pydrake.math import RigidTransform

from mfi_drake.world.mjcf import MAX_DEPTH, rewrite_mjcf
from mfi_drake.world.model_files import (
    MODEL_ENV,
    Prepared,
    env_folders,
    find_package,
    fuel_folders,
    model_file,
    newest_version,
    read_xml,
)
from mfi_drake.world.sdf_rules import (
    CONVEX,
    FRAMED,
    KNOWN,
    SDF,
    URDF,
    numbers,
    pose_matrix,
    pose_text,
)

PART = 250  # models a part (Drake parses 250 in 0.1 s, 2000 in 8 s)


class _Reader:
    """One world file being rewritten: the folders searched, what was read
    past, each element's origin, and the files being included (a loop)."""

    def __init__(self, path: str, model_paths: list[str]) -> None:
        self.path = path
        self.model_paths = list(model_paths)
        self.out = Prepared()
        self.origins: dict[ET.Element, str] = {}
        self.including: list[str] = []
        self.joint_frames: set[ET.Element] = set()  # `joint_frame`'s

    def keep(self, element: ET.Element, rules: dict, folder: str) -> ET.Element | None:
        """A copy of `element` with the children and attributes `rules`
        keep (what it does not is counted), includes expanded; None for a
        collision with no geometry left or a model with no link."""
        children, attributes = rules.get(element.tag, (set(), set()))
        copy = ET.Element(element.tag)
        self.origins[copy] = self.origins[element]
        for key, value in element.attrib.items():
            if key in attributes or key.startswith("xmlns"):
                copy.set(key, value)
            elif key == "frame" and element.tag == "pose":  # SDFormat 1.5–1.6
                if value:
                    copy.set("relative_to", value)
            elif key != "merge":  # a merged include flies as a nested one
                self.out.unknown[f"{key}= on <{element.tag}>"] += 1
        if not children:
            copy.text = " ".join((element.text or "").split())
        for child in element:
            if child.tag == "include" and "include" in children:
                kept = self.include(child, folder)
            elif child.tag in children:
                kept = self.keep(child, rules, folder)
            else:
                self.out.read_past[child.tag] += 1
                if child.tag not in KNOWN:
                    self.out.unknown[f"<{child.tag}>"] += 1
                continue
            if kept is not None:
                copy.append(kept)
        return self.finish(copy, element, folder)

    def finish(
        self, copy: ET.Element, element: ET.Element, folder: str
    ) -> ET.Element | None:
        """What each kind of element becomes once its children are kept."""
        if copy.tag == "collision":
            return self.collision(copy, folder)
        if copy.tag == "joint" and self.out.kind == "urdf":  # held at zero
            copy.set("type", "fixed")
        elif copy.tag == "joint":  # a static model's: the frame poses may name
            return self.joint_frame(copy)
        if copy.tag == "link":
            self.unrepeated(copy)
        if copy.tag == "robot" and not copy.get("name", "").strip():
            # PyBullet reads a robot named "" (its humanoid.urdf); Drake
            # would abort: it is named by its file.
            copy.set("name", os.path.splitext(os.path.basename(self.path))[0])
        if copy.tag == "model":
            if not any(c.tag in ("link", "model") for c in copy):
                return None
            self.loose_joints(copy)
            for old in copy.findall("static"):
                copy.remove(old)
            static = ET.SubElement(copy, "static")
            static.text = "true"
            self.origins[static] = self.origins[copy]
        if copy.tag == "world":
            self.state(copy, element, folder)
        return copy

    def unrepeated(self, link: ET.Element) -> None:
        """Names an SDFormat link "world" (PyBullet's grippers fix their
        base so; a URDF's is Drake's world body) and a link's collisions
        that repeat a name (Gazebo's kiva shelf: ten "pod_collision") apart,
        as Gazebo and PyBullet read them; SDFormat reserves the one and
        Drake refuses the others."""
        if link.get("name") == "world" and self.out.kind == "sdf":
            link.set("name", "world_link")
        seen: Counter = Counter()
        for collision in link.findall("collision"):
            name = collision.get("name")
            if name is not None:
                seen[name] += 1
                if seen[name] > 1:
                    collision.set("name", f"{name}_{seen[name]}")

    def loose_joints(self, model: ET.Element) -> None:
        """Removes the frames of the model's joints SDFormat 1.7 and Drake
        refuse but Gazebo Classic's 1.4–1.6 models hold (its own model
        collection: a joint named as its child link, a joint named "world",
        a child that names nothing): no pose can name such a frame
        unambiguously, so it is read past as its joint would be."""
        frames = [c for c in model if c in self.joint_frames]
        names = Counter(c.get("name") for c in model if c.tag in FRAMED)
        models = {c.get("name") for c in model if c.tag == "model"}
        for frame in frames:
            name, child = frame.get("name", ""), frame.get("attached_to", "")
            reserved = name in ("", "world") or name.startswith("__")
            known = names[child] > 0 or child.split("::")[0] in models
            if reserved or names[name] > 1 or not known:
                model.remove(frame)
                self.out.read_past["joint"] += 1

    def joint_frame(self, joint: ET.Element) -> ET.Element:
        """An SDFormat joint of a static model as the frame it defines
        (attached to its child, posed relative to it unless it says)."""
        child = " ".join((joint.findtext("child") or "").split())
        frame = ET.Element(
            "frame", {"name": joint.get("name", ""), "attached_to": child}
        )
        pose = joint.find("pose")
        if pose is None:
            pose = ET.Element("pose")
            pose.text = "0 0 0 0 0 0"
        if not pose.get("relative_to"):
            pose.set("relative_to", child)
        frame.append(pose)
        self.origins[frame] = self.origins[pose] = self.origins[joint]
        self.joint_frames.add(frame)
        return frame

    def state(self, world: ET.Element, source: ET.Element, folder: str) -> None:
        """The world's <state> applied as Gazebo applies it: its inserted
        models added, its deleted ones removed, and each model's (and
        link's) pose, given in the world frame, the model's own."""
        for state in source.findall("state"):
            for model in state.findall("insertions/model"):
                kept = self.keep(model, SDF, folder)
                if kept is not None:
                    world.append(kept)
            for name in state.findall("deletions/name"):
                for model in _named(world, "model", (name.text or "").strip()):
                    world.remove(model)
            for model in state.findall("model"):
                self.model_state(world, model, RigidTransform())

    def model_state(
        self, parent: ET.Element, state: ET.Element, X_WP: RigidTransform
    ) -> None:
        """One model's state: `X_WP` is its parent's pose in the world."""
        models = _named(parent, "model", state.get("name", ""))
        pose = state.find("pose")
        if not models or pose is None:  # Gazebo ignores what it does not have
            return
        X_WM = pose_matrix(pose, self.origins[pose])
        self.set_pose(models[0], X_WP.inverse() @ X_WM, pose)
        for link in state.findall("link"):
            links = _named(models[0], "link", link.get("name", ""))
            if links and link.find("pose") is not None:
                X_WL = pose_matrix(link.find("pose"), self.origins[link])
                self.set_pose(links[0], X_WM.inverse() @ X_WL, link)
        for nested in state.findall("model"):
            self.model_state(models[0], nested, X_WM)

    def set_pose(self, element: ET.Element, X: RigidTransform, cause) -> None:
        for old in element.findall("pose"):
            element.remove(old)
        pose = ET.Element("pose")
        pose.text = pose_text(X)
        self.origins[pose] = self.origins[cause]
        element.insert(0, pose)

    def include(self, element: ET.Element, folder: str) -> ET.Element | None:
        """The model an <include> names, with its overrides; None for an
        include of lights or actors only."""
        where = self.origins[element]
        uri = (element.findtext("uri") or "").strip()
        if not uri:
            raise ValueError(f"{where}: an <include> needs a <uri>")
        target = self.resolve(uri, folder, where)
        if os.path.isdir(target):
            target = model_file(target, where)
        if not os.path.isfile(target):
            raise ValueError(f"{where}: {uri}: no such file ({target})")
        if len(self.including) >= MAX_DEPTH or target in self.including:
            raise ValueError(f"{where}: {uri} includes itself")
        root, origins = read_xml(target)
        self.origins.update(origins)
        model = root.find("model") if root.tag == "sdf" else None
        # An include may also name a light or an actor (Fuel's "Sun"): read
        # past and counted like those written in the world itself.
        others = (
            [] if root.tag != "sdf" else root.findall("light") + root.findall("actor")
        )
        if model is None and others:
            self.out.read_past.update(other.tag for other in others)
            return None
        if model is None:
            raise ValueError(f"{origins[root]}: {uri} holds no SDFormat <model>")
        self.including.append(target)
        model = self.keep(model, SDF, os.path.dirname(target))
        self.including.pop()
        for key in ("name", "pose"):  # its <static> too, but every model is
            override = element.find(key)
            if override is None:
                continue
            if key == "name":
                model.set("name", " ".join((override.text or "").split()))
                continue
            for old in model.findall(key):
                model.remove(old)
            model.insert(0, self.keep(override, SDF, folder))
        return model

    def resolve(self, uri: str, folder: str, where: str) -> str:
        """The absolute path a URI names, or ValueError naming the model or
        package and the folders searched."""
        scheme, sep, rest = uri.partition("://")
        if not sep:
            return os.path.normpath(os.path.join(folder, uri))
        if scheme == "file":
            return os.path.join(folder, rest)  # `rest` absolute: itself
        # "model:///NAME/…" (turtlebot3's table_marble) names NAME as well.
        name, _, inner = rest.lstrip("/").partition("/")
        if scheme == "model":
            folders = self.model_folders(folder)
            found = [os.path.join(f, name) for f in folders]
            what = f"model {name!r} ({uri})"
        elif scheme == "package":
            folders = [*self.model_paths, *env_folders(("ROS_PACKAGE_PATH",))]
            found = [find_package(name, folders)]
            what = f"package {name!r} ({uri})"
        elif scheme in ("http", "https"):
            name, inner, cached, stand_in = fuel_folders(uri, where)
            folders = [*self.model_folders(folder), *cached]
            found = [os.path.join(f, name) for f in self.model_folders(folder)]
            found += [newest_version(f) for f in cached]
            what = f"Fuel model {name!r} ({uri}; Gazebo downloads it)"
            if stand_in and not any(os.path.isdir(f) for f in found if f):
                self.out.stand_ins[name] += 1
                found.append(stand_in)
        else:
            raise ValueError(f"{where}: {uri}: {scheme}:// is not read")
        for base in found:
            if base and os.path.isdir(base):
                return os.path.join(base, inner)
        searched = ", ".join(dict.fromkeys(folders)) or "no folder"
        raise ValueError(f"{where}: {what} not found in: {searched}")

    def model_folders(self, folder: str) -> list[str]:
        """Where `model://` is searched, from a file in `folder`."""
        beside = [os.path.dirname(folder), os.path.dirname(self.path)]
        return [*self.model_paths, *env_folders(MODEL_ENV), *beside]

    def collision(self, element: ET.Element, folder: str) -> ET.Element | None:
        """A kept collision, its mesh or plane replaced by a numbered
        placeholder box (a mesh's file resolved and checked); None with no
        geometry left."""
        geometry = element.find("geometry")
        if geometry is None or not len(geometry):
            return None
        shape = geometry[0]
        where = self.origins[shape]
        if shape.tag == "plane":
            # SDFormat's <normal>, PyBullet's URDF normal= (plane_implicit).
            written = shape.findtext("normal") or shape.get("normal") or "0 0 1"
            normal = numbers(written, where, "a normal")
            if len(normal) != 3 or not any(normal):
                raise ValueError(f"{where}: a plane's normal must be 3 numbers, not 0")
            self.out.planes.append((normal, where))
            return self.placeholder(element, f"plane_{len(self.out.planes) - 1}")
        if shape.tag == "heightmap":
            return self.heightmap(element, shape, folder, where)
        if shape.tag == "polyline":
            return self.polylines(element, geometry, where)
        if shape.tag != "mesh":
            return element
        uri = (shape.findtext("uri") or shape.get("filename") or "").strip()
        path = self.resolve(uri, folder, where)
        if not os.path.isfile(path):
            raise ValueError(f"{where}: mesh {uri!r}: no such file ({path})")
        if shape.find(CONVEX) is not None:  # Drake reads it as its hull
            if self.out.kind == "urdf":
                shape.set("filename", f"file://{path}")
            else:
                shape.find("uri").text = f"file://{path}"
            return element
        scale = shape.findtext("scale") or shape.get("scale") or "1"
        scale = numbers(scale, where, "a mesh's scale")
        if self.out.kind == "urdf" and len(scale) > 3:
            scale = scale[:3]  # PyBullet's reading (racecar: "1 1 1 1")
        if len(scale) not in (1, 3):
            raise ValueError(f"{where}: a mesh's scale must hold 1 or 3 numbers")
        self.out.meshes.append((path, scale, where))
        return self.placeholder(element, f"mesh_{len(self.out.meshes) - 1}")

    def parts(self, kept: ET.Element) -> list[ET.Element]:
        """A world of more than PART models as worlds of PART models each,
        unless a model is posed relative to another frame or the world
        holds frames (which all parts would need)."""
        world = kept.find("world")
        models = world.findall("model") if world is not None else []
        related = [m.find("pose") for m in models if m.find("pose") is not None]
        if (
            len(models) <= PART
            or world.find("frame") is not None
            or any(pose.get("relative_to") for pose in related)
        ):
            return [kept]
        parts = []
        for k in range(0, len(models), PART):
            sdf, part = (
                ET.Element("sdf", kept.attrib),
                ET.Element("world", world.attrib),
            )
            self.origins[sdf], self.origins[part] = (
                self.origins[kept],
                self.origins[world],
            )
            sdf.append(part)
            part.extend(models[k : k + PART])
            parts.append(sdf)
        return parts

    def heightmap(
        self, collision: ET.Element, shape: ET.Element, folder: str, where: str
    ) -> ET.Element:
        """A terrain's placeholder; its image, size and pos listed for
        `world.terrain` (the image read there)."""
        uri = (shape.findtext("uri") or "").strip()
        path = self.resolve(uri, folder, where)
        if not os.path.isfile(path):
            raise ValueError(f"{where}: heightmap {uri!r}: no such file ({path})")
        size = numbers(shape.findtext("size") or "1 1 1", where, "a heightmap's size")
        pos = numbers(shape.findtext("pos") or "0 0 0", where, "a heightmap's pos")
        if len(size) != 3 or min(size) <= 0.0 or len(pos) != 3:
            raise ValueError(
                f"{where}: a heightmap's size must be 3 positive numbers, its pos 3"
            )
        self.out.heightmaps.append((path, size, pos, where))
        return self.placeholder(collision, f"heightmap_{len(self.out.heightmaps) - 1}")

    def polylines(
        self, collision: ET.Element, geometry: ET.Element, where: str
    ) -> ET.Element:
        """Extruded polygons' placeholder; each polyline's points and
        height listed for `world.extrusions`."""
        shapes = []
        for polyline in geometry.findall("polyline"):
            points = [
                numbers(p.text or "", where, "a polyline's point")
                for p in polyline.findall("point")
            ]
            height = numbers(polyline.findtext("height") or "1", where, "a height")
            if any(len(p) != 2 for p in points) or len(height) != 1:
                raise ValueError(
                    f"{where}: a polyline's points must be 2 numbers, its height 1"
                )
            if height[0] <= 0.0:  # a flat prism is no solid
                raise ValueError(f"{where}: a polyline's height must be positive")
            shapes.append((points, height[0]))
        for extra in geometry.findall("polyline")[1:]:  # the placeholder's
            geometry.remove(extra)
        self.out.polylines.append((shapes, where))
        return self.placeholder(collision, f"polyline_{len(self.out.polylines) - 1}")

    def placeholder(self, collision: ET.Element, mark: str) -> ET.Element:
        """`collision` with a unit box for its shape, renamed with `mark`
        (`sdf_rules.MARK`): Drake poses the box; what it stands for is the
        mark's."""
        name = collision.get("name", "collision")
        collision.set("name", f"__mfi_{mark}__{name}")
        geometry = collision.find("geometry")
        where = self.origins[geometry[0]]
        geometry.remove(geometry[0])
        box = ET.SubElement(geometry, "box")
        if self.out.kind == "urdf":
            box.set("size", "1 1 1")
        else:
            ET.SubElement(box, "size").text = "1 1 1"
        for added in box.iter():
            self.origins[added] = where
        return collision


def _named(parent: ET.Element, tag: str, name: str) -> list[ET.Element]:
    return [e for e in parent.findall(tag) if e.get("name") == name]


def prepare(path: str, model_paths: list[str]) -> Prepared:
    """The world file `path` rewritten for Drake (`Prepared.kind` "mjcf":
    a MuJoCo file, as `mjcf.rewrite_mjcf` says). Raises ValueError, one
    line naming a file and line."""
    root, origins = read_xml(path)
    rules = {"sdf": SDF, "robot": URDF}.get(root.tag)
    if root.tag == "mujoco":
        text, planes, meshes, visual, joints = rewrite_mjcf(path, root, origins)
        out = Prepared(texts=[text], kind="mjcf", planes=planes, meshes=meshes)
        out.read_past["visual"], out.read_past["joint"] = visual, joints
        return out
    if rules is None:
        raise ValueError(
            f"{origins[root]}: the root <{root.tag}> is not SDFormat (<sdf>), "
            "URDF (<robot>) or MJCF (<mujoco>)"
        )
    reader = _Reader(path, model_paths)
    reader.origins.update(origins)
    reader.out.kind = "sdf" if rules is SDF else "urdf"
    kept = reader.keep(root, rules, os.path.dirname(path))
    out = reader.out
    if not len(kept):  # nothing Drake reads (Gazebo's sun: a light alone)
        return out
    for part in reader.parts(kept):
        ET.indent(part)
        out.texts.append(ET.tostring(part, encoding="unicode"))
        again, lines = read_xml("generated", out.texts[-1])
        out.starts.append([int(lines[e].rsplit(":", 1)[1]) for e in again.iter()])
        out.sources.append([reader.origins[e] for e in part.iter()])
    return out
