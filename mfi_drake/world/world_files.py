"""Worlds from the files users already have: the `world:` of a scenario.

An SDFormat (.sdf) or URDF (.urdf) file is parsed with Drake's own `Parser`
into a throwaway MultibodyPlant and SceneGraph; every proximity (collision)
geometry of its static models becomes one of the scenario's own obstacles
(a mesh: its convex pieces, `decomposition`), at its pose in the world and
named after its model and geometry. Loading
appends them to `obstacles` and empties `world`, so the scenario that
travels (as YAML, to a sweep's workers) carries the obstacles, not the path,
and everything that reads `obstacles` reads the world too.
"""

import dataclasses
import os

import numpy as np
from pydrake.geometry import (
    Box,
    Capsule,
    Convex,
    Cylinder,
    Ellipsoid,
    Mesh,
    Role,
    Sphere,
)
from pydrake.math import RollPitchYaw
from pydrake.systems.framework import DiagramBuilder

from mfi_drake.config import scenario as sc
from mfi_drake.world.decomposition import mesh_obstacles, with_meshes
from mfi_drake.world.obstacles import quiet_half_spaces
from mfi_drake.world.point_clouds import with_map

WORLD_SUFFIXES = (".sdf", ".urdf")
# Decimals of a degree that a pose's roll, pitch and yaw are read to: the
# angles recovered from Drake's rotation matrix carry ~1e-14° of rounding,
# which 1e-12° removes and nothing more, so that a pose written in degrees
# (or radians of whole degrees) comes back as the number written and flies
# as the same pose written as `obstacles:` would, bit for bit.
RPY_DECIMALS = 12


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


def world_obstacles(path: str, label: str) -> list[sc.Obstacle]:
    """Every collision geometry of the world file `path` as an obstacle,
    named "world `label` model M geometry G". Raises ValueError, one line
    naming what is wrong, for a file that is missing, unparsable, has a
    model that moves or a geometry of no obstacle shape, or holds no
    collision geometry."""
    if not path.endswith(WORLD_SUFFIXES):
        raise ValueError(
            "must be an SDFormat (.sdf) or URDF (.urdf) file, or a point-cloud "
            "map (.ply, .pcd)"
        )
    if not os.path.isfile(path):
        raise ValueError(f"no such file ({path})")
    # Imported here: pydrake.multibody's import costs ~0.2 s that a scenario
    # without a world does not pay.
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph

    quiet_half_spaces()  # a plane is refused below, in one line
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    try:
        models = Parser(plant).AddModels(path)
        plant.Finalize()
    except RuntimeError as e:  # Drake's message names the line
        raise ValueError(f"not parsable: {str(e).splitlines()[0]}") from None
    welded = {body.index() for body in plant.GetBodiesWeldedTo(plant.world_body())}
    for model in models:
        for index in plant.GetBodyIndices(model):
            if index not in welded:
                name = plant.GetModelInstanceName(model)
                body = plant.get_body(index).name()
                raise ValueError(
                    f"model {name!r} moves (its link {body!r} is not welded to "
                    "the world): a world's models must be static"
                )
    diagram = builder.Build()
    context = scene_graph.GetMyContextFromRoot(diagram.CreateDefaultContext())
    query = scene_graph.get_query_output_port().Eval(context)
    inspector = query.inspector()
    obstacles = []
    for geometry in inspector.GetAllGeometryIds(Role.kProximity):
        body = plant.GetBodyFromFrameId(inspector.GetFrameId(geometry))
        model = plant.GetModelInstanceName(body.model_instance())
        name = inspector.GetName(geometry).removeprefix(f"{model}::")
        where = f"world {label!r} model {model!r} geometry {name!r}"
        shape = inspector.GetShape(geometry)
        if type(shape) not in (*_SHAPES, Mesh):
            raise ValueError(
                f"model {model!r} geometry {name!r}: a {type(shape).__name__} "
                "is no obstacle shape (a plane is given as `ground:`)"
            )
        X_WG = query.GetPoseInWorld(geometry)
        rpy = RollPitchYaw(X_WG.rotation())
        obstacle = sc.Obstacle(
            position=[float(x) for x in X_WG.translation()],
            rpy_deg=[
                round(float(x), RPY_DECIMALS) + 0.0 for x in np.degrees(rpy.vector())
            ],
            name=where,
        )
        if isinstance(shape, Mesh):
            mesh = str(shape.source().path())
            try:
                obstacles += mesh_obstacles(obstacle, mesh, shape.scale3(), where)
            except ValueError as e:
                raise ValueError(f"model {model!r} geometry {name!r}: {e}") from None
        else:
            shape = _SHAPES[type(shape)](shape)
            obstacles.append(dataclasses.replace(obstacle, shape=shape))
    if not obstacles:
        raise ValueError("holds no collision geometry")
    return obstacles


def with_files(scenario: sc.Scenario, where: str) -> sc.Scenario:
    """`scenario` as it flies anywhere: its world file's obstacles after its
    own, `world` emptied (so it resolves once), and each `!Mesh` replaced by
    its convex pieces (`decomposition.with_meshes`); itself without either.
    A point-cloud map instead fills `map_points` (`point_clouds.with_map`).
    Raises ScenarioError naming `where`, the field and the file."""
    if scenario.world.endswith(sc.MAP_SUFFIXES):
        scenario = with_map(scenario, where)
    if scenario.world:
        path = os.path.join(scenario.base_dir, scenario.world)
        try:
            found = world_obstacles(path, scenario.world)
        except ValueError as e:
            sc.fail(where, "world", scenario.world, str(e))
        scenario = dataclasses.replace(
            scenario, obstacles=[*scenario.obstacles, *found], world=""
        )
    return with_meshes(scenario, where)
