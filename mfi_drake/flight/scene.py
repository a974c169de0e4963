"""What a user's SceneGraph holds, as the builder API needs it: which of
its obstacles can move (`scene_moves`) and whether one covers the goal
(`goal_obstacle`). Every proximity geometry is an obstacle but the
vehicle's own (`ignored`)."""

import numpy as np
from pydrake.geometry import FramePoseVector, Role, SceneGraph
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder


def multibody_plants(builder: DiagramBuilder, scene_graph: SceneGraph) -> list:
    """The finalized MultibodyPlants of `builder` whose geometry is in
    `scene_graph`."""
    return [
        s
        for s in builder.GetSystems()
        if isinstance(s, MultibodyPlant)
        and s.is_finalized()
        and s.geometry_source_is_registered()
        and scene_graph.model_inspector().SourceIsRegistered(s.get_source_id())
    ]


def scene_moves(
    builder: DiagramBuilder, scene_graph: SceneGraph, ignored: frozenset
) -> bool:
    """Whether any obstacle can move: a proximity geometry (not the
    vehicle's own) neither anchored nor on a body that a finalized
    MultibodyPlant welds to the world. In a scenario's diagram, exactly
    whether an obstacle has a motion (`world.motion.obstacles_move`)."""
    inspector = scene_graph.model_inspector()
    fixed = {inspector.world_frame_id()}
    for plant in multibody_plants(builder, scene_graph):
        for welded in plant.GetBodiesWeldedTo(plant.world_body()):
            frame = plant.GetBodyFrameIdIfExists(welded.index())
            if frame is not None:
                fixed.add(frame)
    return any(
        inspector.GetFrameId(g) not in fixed
        for g in inspector.GetAllGeometryIds(Role.kProximity)
        if g not in ignored
    )


def goal_obstacle(
    builder: DiagramBuilder,
    scene_graph: SceneGraph,
    goal,
    radius: float,
    ignored: frozenset,
) -> tuple[str, float] | None:
    """(name, distance) of an obstacle closer to `goal` than `radius`, or
    None: anchored geometry, and a finalized MultibodyPlant's posed at its
    default context, read with SceneGraph's own signed distance query in a
    context of its own. Other sources' frames are posed anywhere there and
    their geometry is not checked."""
    inspector = scene_graph.model_inspector()
    context = scene_graph.CreateDefaultContext()
    world = inspector.world_frame_id()
    known = {world}
    posed = set()
    for plant in multibody_plants(builder, scene_graph):
        poses = plant.get_geometry_pose_output_port().Eval(plant.CreateDefaultContext())
        scene_graph.get_source_pose_port(plant.get_source_id()).FixValue(context, poses)
        known.update(poses.ids())
        posed.add(plant.get_source_id())
    for source in inspector.GetAllSourceIds():
        frames = [f for f in inspector.FramesForSource(source) if f != world]
        if source not in posed and frames:
            anywhere = FramePoseVector()
            for frame in frames:
                anywhere.set_value(frame, RigidTransform())
            scene_graph.get_source_pose_port(source).FixValue(context, anywhere)
    query = scene_graph.get_query_output_port().Eval(context)
    for r in query.ComputeSignedDistanceToPoint(np.asarray(goal, float), radius):
        if (
            r.distance < radius
            and r.id_G not in ignored
            and inspector.GetFrameId(r.id_G) in known
        ):
            return inspector.GetName(r.id_G), r.distance
    return None
