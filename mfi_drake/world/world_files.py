"""Worlds from the files users already have: the `world:` of a scenario.

A Gazebo world or model (.world, .sdf), a URDF (.urdf) or a MuJoCo MJCF
(.xml) is rewritten as `sdformat.prepare` says (includes resolved, what
does not fly read past, every model static where its file or its
`<state>` puts it), parsed with Drake's own `Parser` into a throwaway
MultibodyPlant and SceneGraph, and every proximity (collision) geometry
becomes one of the scenario's own obstacles (a mesh: its convex pieces,
`decomposition`), at its pose placed by `world_pose`, named after its model
and geometry; a plane facing up is the scenario's ground. Loading appends
them to `obstacles` and empties `world`, so the scenario that travels (as
YAML, to a sweep's workers) carries the obstacles, not the path, and
everything that reads `obstacles` reads the world too.
"""

import dataclasses
import logging
import os
import re
import warnings
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import (
    Box,
    Capsule,
    Convex,
    Cylinder,
    Ellipsoid,
    HalfSpace,
    Mesh,
    Role,
    Sphere,
)
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.systems.framework import DiagramBuilder

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import Ground
from mfi_drake.config.worlds import ScenarioWarning, WorldPose
from mfi_drake.world.decomposition import (
    hull_pieces,
    mesh_obstacles,
    placed_pieces,
    prefetch_pieces,
    with_meshes,
)
from mfi_drake.world.extrusions import prisms
from mfi_drake.world.model_files import Prepared
from mfi_drake.world.point_clouds import with_map
from mfi_drake.world.sdf_rules import MARK
from mfi_drake.world.sdformat import prepare
from mfi_drake.world.terrain import read_heights, terrain_columns

WORLD_SUFFIXES = (".sdf", ".world", ".urdf", ".xml", ".mjcf")
# Decimals of a degree that a pose's roll, pitch and yaw are read to: the
# angles recovered from Drake's rotation matrix carry ~1e-14° of rounding,
# which 1e-12° removes and nothing more, so that a pose written in degrees
# (or radians of whole degrees) comes back as the number written and flies
# as the same pose written as `obstacles:` would, bit for bit.
RPY_DECIMALS = 12
SLAB = (1000.0, 1000.0, 10.0)  # m: a plane that is not the ground, flown as this


def _hull(shape: Convex) -> sc.Convex:
    """A convex geometry's hull, scaled, its vertices inline: it reads no
    file once loaded, so it flies on a worker that cannot see the mesh."""
    hull = shape.GetConvexHull()
    vertices = [[float(x) for x in hull.vertex(i)] for i in range(hull.num_vertices())]
    return sc.Convex(vertices=vertices)


# Drake's shape -> the scenario's (a mesh of any shape: `world.decomposition`).
_SHAPES = {
    Box: lambda s: sc.Box(size=[s.width(), s.depth(), s.height()]),
    Sphere: lambda s: sc.Sphere(radius=s.radius()),
    Cylinder: lambda s: sc.Cylinder(radius=s.radius(), length=s.length()),
    Capsule: lambda s: sc.Capsule(radius=s.radius(), length=s.length()),
    Ellipsoid: lambda s: sc.Ellipsoid(radii=[s.a(), s.b(), s.c()]),
    Convex: _hull,
}


@dataclass
class World:
    """What a world file holds: its obstacles, the height of its highest
    upward plane (None: none) and what was read past, in one line."""

    obstacles: list[sc.Obstacle]
    ground: float | None
    notes: str


class _DrakeWarnings(logging.Handler):
    """Drake's warnings while a file is parsed, gathered for one line."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(" ".join(record.getMessage().split()))


def _parse(
    path: str, prepared: Prepared, part: int, plant, heard: _DrakeWarnings
) -> list:
    """The model instances Drake's Parser adds for part `part` of the file;
    RuntimeError turned into ValueError naming the file and line of its
    cause."""
    from pydrake.multibody.parsing import Parser

    logger = logging.getLogger("drake")
    logger.addHandler(heard)
    propagates, logger.propagate = logger.propagate, False
    try:
        parser = Parser(plant)
        kind = "xml" if prepared.kind == "mjcf" else prepared.kind
        return parser.AddModelsFromString(prepared.texts[part], kind)
    # SystemExit: a failed Drake check; ValueError: a bad number in a URDF.
    except (RuntimeError, ValueError, SystemExit) as e:
        lines = [line for line in str(e).splitlines() if line.strip()] or ["?"]
        cause = lines[0]
        found = re.search(r":(\d+): (?:error: )?(.*)", cause)
        if found and prepared.kind != "mjcf":
            cause = f"{prepared.source(part, int(found[1]))}: {found[2]}"
        elif not cause.startswith(path):
            cause = f"{path}: {cause}"
        if heard.messages:  # Drake's own cause is often a warning before it
            cause += f" (Drake warned: {heard.messages[-1]})"
        raise ValueError(cause) from None
    finally:
        logger.removeHandler(heard)
        logger.propagate = propagates


def world_obstacles(
    path: str,
    label: str,
    model_paths: list[str] = (),
    X_SW: RigidTransform | None = None,
) -> World:
    """Every collision geometry of the world file `path`, placed by X_SW
    (the file's frame in the scenario's), as an obstacle named "world
    `label` model M geometry G"; `model_paths` are searched first for its
    includes. Raises ValueError, one line naming the file (and the line
    of the cause), for a file that is missing, unparsable, or has a
    geometry of no obstacle shape, or that holds no collision geometry."""
    if not path.lower().endswith(WORLD_SUFFIXES):
        raise ValueError(
            "must be a Gazebo world or model (.world, .sdf), a URDF (.urdf), "
            "an MJCF (.xml) file, or a point-cloud map (.ply, .pcd, .las, .laz, "
            ".xyz, .pts)"
        )
    if not os.path.isfile(path):
        raise ValueError(f"no such file ({path})")
    X_SW = X_SW if X_SW is not None else RigidTransform()
    prepared = prepare(path, list(model_paths))
    # Its meshes decomposed at once over the cores, into the cache that
    # each geometry's `mesh_obstacles` reads below; a MuJoCo mesh collides
    # as its convex hull, one piece.
    meshes = [(mesh, scale) for mesh, scale, _ in prepared.meshes]
    prepared.pieces = (hull_pieces if prepared.kind == "mjcf" else prefetch_pieces)(
        meshes
    )
    heard = _DrakeWarnings()
    obstacles, grounds = [], []
    for part in range(len(prepared.texts)):
        for found, ground in _part(path, prepared, part, heard, X_SW, label):
            obstacles += found
            grounds += [] if ground is None else [ground]
    notes = prepared.summary()
    if not obstacles and not grounds:  # what it held instead, if anything
        raise ValueError(
            "holds no collision geometry" + (f" ({notes})" if notes else "")
        )
    if heard.messages:
        # Drake names the text it parsed "<literal-string>.urdf" and its
        # line; a rewritten text's lines are no file's.
        first = re.sub(r"^<literal-string>\.\w+:\d+: ", "", heard.messages[0])
        notes += "; " if notes else ""
        notes += f"{len(heard.messages)} Drake warnings (the first: {first})"
    return World(obstacles, max(grounds, default=None), notes)


def _part(
    path: str,
    prepared: Prepared,
    part: int,
    heard: _DrakeWarnings,
    X_SW: RigidTransform,
    label: str,
) -> list[tuple[list[sc.Obstacle], float | None]]:
    """Each collision geometry of one part of a prepared file, parsed into
    a throwaway plant: its obstacles and the ground's height it makes
    (`_obstacles`)."""
    # Imported here: pydrake.multibody's import costs ~0.2 s that a scenario
    # without a world does not pay.
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph

    plant, scene_graph = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.0)
    _parse(path, prepared, part, plant, heard)
    try:
        plant.Finalize()
    except (RuntimeError, SystemExit) as e:
        raise ValueError(f"{path}: {str(e).splitlines()[0]}") from None
    # Every model stands where its file puts it (its joints at their
    # defaults): the plant's default poses, composed here, not by a
    # SceneGraph context, whose broadphase (FCL) crashes with a half space
    # among thousands of geometries.
    context = plant.CreateDefaultContext()
    inspector = scene_graph.model_inspector()
    return [
        _obstacles(
            plant,
            inspector,
            geometry,
            X_SW @ _pose(plant, context, inspector, geometry),
            prepared,
            label,
        )
        for geometry in inspector.GetAllGeometryIds(Role.kProximity)
    ]


def _pose(plant, context, inspector, geometry) -> RigidTransform:
    """X_WG: a geometry's pose in the world, its body's composed with its
    own in the body."""
    body = plant.GetBodyFromFrameId(inspector.GetFrameId(geometry))
    X_WB = plant.EvalBodyPoseInWorld(context, body)
    return X_WB @ inspector.GetPoseInFrame(geometry)


def _obstacles(
    plant, inspector, geometry, X_SG: RigidTransform, prepared: Prepared, label: str
) -> tuple[list[sc.Obstacle], float | None]:
    """One collision geometry, at X_SG in the scenario: (its obstacles (a
    mesh: its convex pieces; a terrain: its columns), the height of the
    ground it makes (a plane facing up, a terrain's lowest level) or
    None)."""
    body = plant.GetBodyFromFrameId(inspector.GetFrameId(geometry))
    model = plant.GetModelInstanceName(body.model_instance())
    name = inspector.GetName(geometry).removeprefix(f"{model}::")
    mark = MARK.search(name)
    if mark:
        name = name[: mark.start()] + mark[3]
    where = f"world {label!r} model {model!r} geometry {name!r}"
    shape = inspector.GetShape(geometry)
    if isinstance(shape, HalfSpace) or (mark and mark[1] == "plane"):
        normal = prepared.planes[int(mark[2])][0] if mark else [0, 0, 1]
        n_S = X_SG.rotation().matrix() @ normal
        n_S = n_S / np.linalg.norm(n_S)
        if n_S[2] >= 1.0 - 1e-9:
            return [], float(X_SG.translation()[2])
        # A plane not facing up: a slab under it (the ground is horizontal).
        p_S = X_SG.translation() - n_S * SLAB[2] / 2
        X_SG = RigidTransform(RotationMatrix.MakeFromOneVector(n_S, 2), p_S)
        shape = Box(*SLAB)
    if type(shape) not in (*_SHAPES, Mesh):
        raise ValueError(
            f"model {model!r} geometry {name!r}: a {type(shape).__name__} "
            "is no obstacle shape"
        )
    rpy = RollPitchYaw(X_SG.rotation())
    obstacle = sc.Obstacle(
        position=[float(x) for x in X_SG.translation()],
        rpy_deg=[round(float(x), RPY_DECIMALS) + 0.0 for x in np.degrees(rpy.vector())],
        name=where,
    )
    if mark and mark[1] == "heightmap":
        return _terrain(prepared.heightmaps[int(mark[2])], obstacle, X_SG)
    if mark and mark[1] == "polyline":
        return _extruded(prepared.polylines[int(mark[2])], obstacle), None
    mesh = mark and mark[1] == "mesh"
    if mesh or isinstance(shape, Mesh):
        path, scale, origin = (
            prepared.meshes[int(mark[2])]
            if mesh
            else (str(shape.source().path()), shape.scale3(), "")
        )
        try:
            return mesh_obstacles(obstacle, path, scale, where, prepared.pieces), None
        except ValueError as e:
            cause = f"model {model!r} geometry {name!r}: {e}"
            raise ValueError(f"{origin}: {cause}" if origin else cause) from None
    return [dataclasses.replace(obstacle, shape=_SHAPES[type(shape)](shape))], None


def _extruded(polylines: tuple, placed: sc.Obstacle) -> list[sc.Obstacle]:
    """Extruded polygons where `placed` (their collision at its pose in the
    scenario) puts them: each triangle's prism a convex piece
    (`world.extrusions`, `decomposition.placed_pieces`)."""
    shapes, origin = polylines
    pieces = []
    for points, height in shapes:
        try:
            pieces += prisms(points, height)
        except ValueError as e:
            raise ValueError(f"{origin}: {placed.name}: {e}") from None
    return placed_pieces(placed, pieces, placed.name)


def _terrain(
    heightmap: tuple, placed: sc.Obstacle, X_SG: RigidTransform
) -> tuple[list[sc.Obstacle], float]:
    """A terrain's columns where `placed` (its collision's pose X_SG in the
    scenario, and its name) puts them, and its lowest level the ground
    (`world.terrain`): its frame must face up, as the ground does."""
    path, size, pos, origin = heightmap
    if X_SG.rotation().matrix()[2, 2] < 1.0 - 1e-9:
        raise ValueError(f"{origin}: {placed.name}: a heightmap must face up (+z)")
    try:
        ground, columns = terrain_columns(read_heights(path), size, pos)
    except ValueError as e:
        raise ValueError(f"{origin}: heightmap {path}: {e}") from None
    return [
        dataclasses.replace(
            placed,
            shape=sc.Box(size=box),
            position=[float(x) for x in X_SG.multiply(np.asarray(centre))],
            name=f"{placed.name} column {k}",
        )
        for k, (centre, box) in enumerate(columns)
    ], float(X_SG.translation()[2] + ground)


def _placed(points: list[list[float]], X_SW: RigidTransform) -> list[list[float]]:
    """A cloud's points (n, 3) in the scenario's frame."""
    return (X_SW.multiply(np.asarray(points, float).T).T).tolist()


def _beside(text: str, scenario: sc.Scenario) -> str:
    """`text` naming the files beside the YAML file as the YAML names them."""
    return text.replace(os.path.join(scenario.base_dir, ""), "")


def with_files(scenario: sc.Scenario, where: str) -> sc.Scenario:
    """`scenario` as it flies anywhere: its world file's obstacles after its
    own (its upward plane its ground, unless it has one: then its own is
    kept and a warning says so), `world` and `world_pose` emptied (so it
    resolves once), and each `!Mesh` replaced by its convex pieces
    (`decomposition.with_meshes`); itself without either. A point-cloud map
    instead fills `map_points` (`point_clouds.with_map`), placed by
    `world_pose`. What a world file holds and a flight does not read is
    one ScenarioWarning. Raises ScenarioError naming `where`, the field and
    the file."""
    pose = scenario.world_pose
    X_SW = RigidTransform(RollPitchYaw(np.radians(pose.rpy_deg)), pose.position)
    if scenario.world.lower().endswith(sc.MAP_SUFFIXES):
        scenario = with_map(scenario, where)
        points = _placed(scenario.map_points, X_SW)
        scenario = dataclasses.replace(
            scenario, map_points=points, world_pose=WorldPose()
        )
    if scenario.world:
        path = os.path.join(scenario.base_dir, scenario.world)
        folders = [os.path.join(scenario.base_dir, f) for f in scenario.model_paths]
        try:
            found = world_obstacles(path, scenario.world, folders, X_SW)
        except ValueError as e:
            sc.fail(where, "world", scenario.world, _beside(str(e), scenario))
        notes = [_beside(found.notes, scenario)] if found.notes else []
        ground = scenario.ground
        if found.ground is not None and ground is not None:
            notes.append(
                f"its ground plane at z = {found.ground:g} m is not read: the "
                f"scenario's ground (z = {ground.height:g} m) is kept"
            )
        elif found.ground is not None:
            ground = Ground(height=found.ground)
        if notes:
            warnings.warn(
                f"{where}: world = {scenario.world!r}: {'; '.join(notes)}",
                ScenarioWarning,
                stacklevel=2,
            )
        scenario = dataclasses.replace(
            scenario,
            obstacles=[*scenario.obstacles, *found.obstacles],
            ground=ground,
            world="",
            world_pose=WorldPose(),
        )
    return with_meshes(scenario, where)
