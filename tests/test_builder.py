"""The builder API as a Drake user meets it: MFI added to their own diagram
(an SDFormat world parsed into their SceneGraph, their QuadrotorPlant, their
Simulator), only through `from mfi_drake import ...`."""

import math
import pathlib
from dataclasses import replace

import numpy as np
import pytest
from pydrake.examples import QuadrotorPlant
from pydrake.geometry import (
    Box,
    GeometryInstance,
    ProximityProperties,
    SceneGraph,
    Sphere,
)
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from mfi_drake import (
    BuilderError,
    DepthCameraRig,
    Faults,
    NavigatorParams,
    SphereSensor,
    add_navigation,
    add_sensor,
    add_vehicle_model,
    apply_simulator_config,
    default_simulator_config,
    load_scenario,
    simulate,
)

DATA = pathlib.Path(__file__).parent / "data"
YARD = pathlib.Path(__file__).parents[1] / "examples" / "yard.sdf"  # examples' world
START = [0.0, 0.0, 1.5]
GOAL = [12.0, 0.0, 1.5]


def yard(builder: DiagramBuilder):
    """The user's world: examples/yard.sdf parsed into the plant and
    SceneGraph of AddMultibodyPlantSceneGraph."""
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    Parser(plant).AddModels(str(YARD))
    plant.Finalize()
    return plant, scene_graph


def yard_clearance(p: np.ndarray) -> np.ndarray:
    """Distance of each point of p (N, 3) to the yard's surfaces, in closed
    form (examples/yard.sdf: box, upright cylinder, sphere)."""
    half = np.array([0.2, 1.5, 1.5])
    q = np.abs(p - [4.0, 0.5, 1.5]) - half
    box = np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)
    radial = np.linalg.norm(p[:, :2] - [8.0, -0.8], axis=1) - 0.3
    height = np.abs(p[:, 2] - 1.5) - 1.5
    outside = np.hypot(np.maximum(radial, 0.0), np.maximum(height, 0.0))
    post = outside + np.minimum(np.maximum(radial, height), 0.0)
    boulder = np.linalg.norm(p - [10.0, 0.9, 1.0], axis=1) - 0.7
    return np.minimum(np.minimum(box, post), boulder)


def fly_from_start(builder, handles, duration: float = 30.0):
    """Builds the user's diagram, flies it with their own Simulator (and the
    one line eq 21's witnesses need) from START; the logged (times, log)."""
    simulator = Simulator(builder.Build())
    apply_simulator_config(default_simulator_config(), simulator)
    context = simulator.get_mutable_context()
    handles.set_start(context, START)
    simulator.AdvanceTo(duration)
    return handles.read_log(context)


def test_a_users_yard_flies_as_the_scenario_of_the_same_shapes():
    builder = DiagramBuilder()
    _, scene_graph = yard(builder)
    quadrotor = builder.AddSystem(QuadrotorPlant())
    handles = add_navigation(
        builder, plant=quadrotor, scene_graph=scene_graph, goal=GOAL
    )
    times, log = fly_from_start(builder, handles)

    p = log["state"][:, :3]
    assert np.linalg.norm(p[-1] - GOAL) < 0.1
    radius = handles.vehicle.collision_radius
    assert yard_clearance(p).min() > radius  # no contact
    assert yard_clearance(p).min() < radius + 1.0  # it flew among the shapes

    # Bit for bit: the same shapes at the same poses (translations only, so
    # the plant's welds pose them exactly where the anchored ones are), the
    # same sensor, chain and integrator; the plant has no state, so the
    # error norm and every step are the scenario's.
    flight = simulate(load_scenario(str(DATA / "yard.yaml")))
    assert np.array_equal(times, flight.times)
    assert log.keys() == flight.log.keys()
    for name in log:
        assert np.array_equal(log[name], flight.log[name]), name


def empty_scene(goal=(2.0, 0.0, 1.5)):
    builder = DiagramBuilder()
    scene_graph = builder.AddSystem(SceneGraph())
    quadrotor = builder.AddSystem(QuadrotorPlant())
    handles = add_navigation(
        builder, plant=quadrotor, scene_graph=scene_graph, goal=list(goal)
    )
    return builder.Build(), handles


def test_a_plain_simulator_needs_the_accuracy_helper():
    diagram, handles = empty_scene()
    simulator = Simulator(diagram)
    handles.set_start(simulator.get_mutable_context(), START)
    # Eq 21's witness (the switch to the goal PD) needs the context's accuracy.
    with pytest.raises(RuntimeError, match="accuracy is not set in the context"):
        simulator.AdvanceTo(10.0)

    diagram, handles = empty_scene()
    simulator = Simulator(diagram)
    apply_simulator_config(default_simulator_config(), simulator)
    context = simulator.get_mutable_context()
    handles.set_start(context, START)
    simulator.AdvanceTo(10.0)
    _, log = handles.read_log(context)
    assert np.linalg.norm(log["state"][-1, :3] - [2.0, 0.0, 1.5]) < 0.1
    assert len(np.unique(log["mode"])) > 1  # eq 21 switched mode


def builder_with(*, multibody: bool = False, finalize: bool = True):
    """A builder holding the yard (its MultibodyPlant) and a QuadrotorPlant."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    Parser(plant).AddModels(str(YARD))
    if finalize:
        plant.Finalize()
    quadrotor = builder.AddSystem(QuadrotorPlant())
    return builder, (plant if multibody else quadrotor), scene_graph


def anchored_box(builder):
    """A SceneGraph with the user's own anchored box at [5, 0, 1.5]."""
    scene_graph = builder.AddSystem(SceneGraph())
    source = scene_graph.RegisterSource("user")
    box = GeometryInstance(RigidTransform([5.0, 0.0, 1.5]), Box(1, 1, 1), "crate")
    box.set_proximity_properties(ProximityProperties())
    scene_graph.RegisterAnchoredGeometry(source, box)
    return scene_graph


BAD = {
    "a plant of another type": (
        lambda b, q, sg: {"plant": b.AddSystem(ConstantVectorSource([0.0]))},
        r"^plant = ConstantVectorSource",
    ),
    "a plant not in builder": (
        lambda b, q, sg: {"plant": QuadrotorPlant()},
        r"^plant = .*not in builder",
    ),
    "a scene graph of another type": (
        lambda b, q, sg: {"scene_graph": q},
        r"^scene_graph = QuadrotorPlant",
    ),
    "a body with a QuadrotorPlant": (
        lambda b, q, sg: {"body": "wall"},
        r"^body = 'wall': only a MultibodyPlant",
    ),
    "an unknown vehicle": (
        lambda b, q, sg: {"vehicle": "blimp"},
        r"^add_navigation: vehicle = 'blimp'",
    ),
    "an unknown method": (
        lambda b, q, sg: {"method": "teleport"},
        r"^method = 'teleport'",
    ),
    "a goal of two numbers": (lambda b, q, sg: {"goal": [1.0, 2.0]}, r"^goal = "),
    "a goal with a nan": (
        lambda b, q, sg: {"goal": [1.0, math.nan, 2.0]},
        r"^goal = .*finite",
    ),
    "a goal of text": (lambda b, q, sg: {"goal": "here"}, r"^goal = 'here'"),
    "a goal in the parsed wall": (
        lambda b, q, sg: {"goal": [4.0, 0.5, 1.5]},
        r"^goal = .*'yard::wall'",
    ),
    "a goal grazing the parsed boulder": (
        lambda b, q, sg: {"goal": [10.0, 0.9, 1.0 + 0.7 + 0.1]},
        r"^goal = .*'yard::boulder'",
    ),
    "a goal in the user's own box": (
        lambda b, q, sg: {"goal": [5.0, 0.0, 1.5], "scene_graph": anchored_box(b)},
        r"^goal = .*'crate'",
    ),
    "a sensor of another type": (
        lambda b, q, sg: {"sensor": "lidar"},
        r"^add_navigation: sensor = 'lidar'",
    ),
    "an unknown navigator field": (
        lambda b, q, sg: {"navigator": {"gain": 1.0}},
        r"^navigator.gain = 1.0: unknown field",
    ),
    "a navigator value out of range": (
        lambda b, q, sg: {"navigator": NavigatorParams(r_l=1.0, r_b=2.0)},
        r"^add_navigation: navigator.r_b = 2.0",
    ),
    "faults of another type": (
        lambda b, q, sg: {"faults": {"dropout_prob": 0.5}},
        r"^faults = ",
    ),
    "a fault value out of range": (
        lambda b, q, sg: {"faults": Faults(dropout_prob=2.0)},
        r"^add_navigation: faults.dropout_prob = 2.0",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_argument_is_named(case):
    builder, quadrotor, scene_graph = builder_with()
    change, message = BAD[case]
    arguments = {"plant": quadrotor, "scene_graph": scene_graph, "goal": GOAL}
    arguments |= change(builder, quadrotor, scene_graph)
    with pytest.raises(BuilderError, match=message):
        add_navigation(builder, **arguments)
    # The oracle: the same builder takes the good arguments.
    good = add_navigation(builder, plant=quadrotor, scene_graph=scene_graph, goal=GOAL)
    assert good.navigator.get_name() == "navigator"


MULTIBODY_BAD = {
    "not finalized": ({"body": "wall"}, False, r"^plant = .*must be finalized"),
    "no body": ({}, True, r"^body: missing"),
    "an unknown body": ({"body": "rotor"}, True, r"^body = 'rotor': no body"),
    "a welded body": ({"body": "wall"}, True, r"^body = 'wall': is not a floating"),
}


@pytest.mark.parametrize("case", sorted(MULTIBODY_BAD))
def test_a_bad_multibody_vehicle_is_named(case):
    change, finalize, message = MULTIBODY_BAD[case]
    builder, plant, scene_graph = builder_with(multibody=True, finalize=finalize)
    assert isinstance(plant, MultibodyPlant)
    with pytest.raises(BuilderError, match=message):
        add_navigation(
            builder, plant=plant, scene_graph=scene_graph, goal=GOAL, **change
        )


def test_the_sensor_ignores_the_vehicles_own_geometry():
    def reading(own: bool, ignore: bool) -> np.ndarray:
        builder = DiagramBuilder()
        scene_graph = anchored_box(builder)
        ignored = []
        if own:  # a sphere about the vehicle, registered by the user
            source = scene_graph.RegisterSource("vehicle")
            sphere = GeometryInstance(
                RigidTransform([3.5, 0.2, 1.5]), Sphere(0.3), "me"
            )
            sphere.set_proximity_properties(ProximityProperties())
            own_id = scene_graph.RegisterAnchoredGeometry(source, sphere)
            ignored = [own_id] if ignore else []
        state = np.zeros(12)
        state[:3] = [3.5, 0.2, 1.5]
        source = builder.AddSystem(ConstantVectorSource(state))
        sensor = add_sensor(
            builder,
            SphereSensor(radius=3.0),
            scene_graph,
            source.get_output_port(),
            ignore=ignored,
        )
        diagram = builder.Build()
        context = diagram.CreateDefaultContext()
        return sensor.GetOutputPort("obstacle").Eval(
            sensor.GetMyContextFromRoot(context)
        )

    alone = reading(own=False, ignore=False)
    assert np.array_equal(reading(own=True, ignore=True), alone)
    # Not ignored, the own sphere (the vehicle inside it) is the nearest:
    # r_o = −d ∇d with d = −0.3 points 0.3 m away.
    seen = reading(own=True, ignore=False)
    assert np.linalg.norm(seen[:3]) == pytest.approx(0.3)
    assert not np.array_equal(seen, alone)
    # The box's face at x = 4.5 is 1 m away along +x.
    assert alone[:3] == pytest.approx([1.0, 0.0, 0.0])


@pytest.mark.parametrize("scene", ["faults", "cameras", "moving"])
def test_build_diagram_is_the_public_pieces(scene):
    # A scenario's diagram holds its SceneGraph (with the obstacles' motion
    # where they move) and QuadrotorPlant and exactly the systems
    # add_navigation adds to a user's, in its order: moving obstacles in
    # the user's SceneGraph give the same relative navigator.
    from mfi_drake.flight.diagram import build_diagram
    from mfi_drake.systems.motion import ObstacleMotion
    from mfi_drake.world.obstacles import register_obstacles

    scenarios = pathlib.Path(__file__).parents[1] / "scenarios"
    name = {"faults": "planar_wall_faults", "moving": "moving_crossing"}
    scenario = load_scenario(str(scenarios / f"{name.get(scene, 'planar_wall')}.yaml"))
    if scene == "cameras":
        scenario = replace(scenario, sensor=DepthCameraRig())
    built = build_diagram(scenario).diagram

    builder = DiagramBuilder()
    scene_graph = builder.AddNamedSystem("scene_graph", SceneGraph())
    if scene == "moving":
        frames = register_obstacles(scene_graph, scenario)
        motion = builder.AddNamedSystem("obstacle_motion", ObstacleMotion(frames))
        builder.Connect(
            motion.get_output_port(), scene_graph.get_source_pose_port(frames.source_id)
        )
    quadrotor = builder.AddNamedSystem("quadrotor", QuadrotorPlant())
    add_navigation(
        builder,
        plant=quadrotor,
        scene_graph=scene_graph,
        goal=scenario.goal,
        sensor=scenario.sensor,
        navigator=scenario.navigator,
        faults=scenario.faults,
    )
    users = builder.Build()

    def systems(diagram):
        return [(s.get_name(), type(s).__name__) for s in diagram.GetSystems()]

    assert systems(built) == systems(users)


def test_a_multibody_vehicle_in_the_yard_flies_the_quadrotors_path():
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    Parser(plant).AddModels(str(YARD))
    body = add_vehicle_model(plant, "drake_default")
    plant.Finalize()
    handles = add_navigation(
        builder, plant=plant, scene_graph=scene_graph, goal=GOAL, body=body.name()
    )
    times, log = fly_from_start(builder, handles)
    p = log["state"][:, :3]
    # The vehicle's own collision sphere is never read as an obstacle.
    assert handles.ignored
    seen = log["obstacle"].reshape(len(times), -1, 4)  # [r_o, seen] per reading
    distances = np.linalg.norm(seen[..., :3], axis=2)[seen[..., 3] > 0.5]
    assert distances.min() > handles.vehicle.collision_radius
    assert np.linalg.norm(p[-1] - GOAL) < 0.1
    assert yard_clearance(p).min() > handles.vehicle.collision_radius
    # Two plants, one physics: the same outcome, and the QuadrotorPlant's
    # path within 1e-3 m (measured 3.8e-5 m over 1,248 against 1,245 steps:
    # the integrator's error control, at accuracy 1e-4, takes other steps on
    # the MultibodyPlant's 13 quaternion states than on 12 rpy ones).
    flight = simulate(load_scenario(str(DATA / "yard.yaml")))
    q = np.column_stack(
        [np.interp(times, flight.times, flight.positions[:, d]) for d in range(3)]
    )
    assert flight.metrics["outcome"] == "success"
    assert np.abs(p - q).max() < 1e-3


def test_two_vehicles_on_one_builder_are_named_apart_and_fly():
    """Two add_navigation calls on one builder: the second vehicle's systems
    are "vehicle_1/NAME" (Drake's Build() stopped the process on the
    repeated names), a third's "vehicle_2/NAME", and each vehicle reaches
    its own goal past the user's box (QuadrotorPlant vehicles have no
    geometry: they do not read each other)."""
    builder = DiagramBuilder()
    scene_graph = anchored_box(builder)
    goals = ([8.0, 0.0, 1.5], [8.0, 3.0, 1.5], [8.0, -3.0, 1.5])
    fleet = []
    for goal in goals:
        quadrotor = builder.AddSystem(QuadrotorPlant())
        fleet.append(add_navigation(builder, quadrotor, scene_graph, goal=goal))
    names = [handles.navigator.get_name() for handles in fleet]
    assert names == ["navigator", "vehicle_1/navigator", "vehicle_2/navigator"]
    simulator = Simulator(builder.Build())
    apply_simulator_config(default_simulator_config(), simulator)
    context = simulator.get_mutable_context()
    for handles, goal in zip(fleet, goals, strict=True):
        handles.set_start(context, [0.0, goal[1], 1.5])
    simulator.AdvanceTo(20.0)
    for handles, goal in zip(fleet, goals, strict=True):
        _, log = handles.read_log(context)
        assert np.linalg.norm(log["state"][-1, :3] - goal) < 0.1
