"""The pieces of the navigation chain, each added to a user's DiagramBuilder
in the style of Drake's `Apply*Config(config, builder)`:

    state ──▶ add_sensor ──obstacle──▶ add_controller ──rotor forces──▶ plant
                                         navigator → selector → attitude PD → mixer
    add_logger: every signal of LOG_LAYOUT into one VectorLogSink

`state` is an output port of the vehicle's 12-vector in QuadrotorPlant's
convention [p, rpy, ṗ, ω_B]; the rotor forces are the 4 inputs of
QuadrotorPlant (or of the Propeller that drives a MultibodyPlant vehicle).
`flight.builder.add_navigation` puts the three together around a plant;
a user who wants only the sensor or only the controller calls one.
"""

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import FrameId, GeometryId, Role, SceneGraph
from pydrake.systems.framework import (
    DiagramBuilder,
    InputPort,
    LeafSystem,
    OutputPort,
    System,
)
from pydrake.systems.primitives import LogVectorOutput, Multiplexer, VectorLogSink

from mfi_drake.config.faults import Faults
from mfi_drake.config.navigation import NavigationConfig, check_navigation
from mfi_drake.config.scenario import Sensor, SphereSensor
from mfi_drake.config.sensors import Cameras
from mfi_drake.config.vehicles import Vehicle, as_vehicle
from mfi_drake.flight.methods import Method, resolve_method
from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    OBSTACLE_SIGNAL_SIZE,
    READING_SIZE,
    ROTORS,
    STATE_SIZE,
    signal_size,
    slices,
)
from mfi_drake.maths.motion import PACE_BLEND_SPEED
from mfi_drake.systems.camera import add_depth_cameras
from mfi_drake.systems.control import AttitudePD, RotorMixer
from mfi_drake.systems.exchange import OtherVehicleReadings, OtherVehicleSpheres
from mfi_drake.systems.faults import (
    add_rotor_faults,
    add_sensor_faults,
    add_state_estimate,
)
from mfi_drake.systems.navigation import ObstacleNavigator
from mfi_drake.systems.point_map import PointMapSensor
from mfi_drake.systems.relative import RelativeNavigator, relative_navigator
from mfi_drake.systems.sensors import SphereSensor as SphereSensorSystem
from mfi_drake.systems.sensors import VehicleGeometry

# What the log holds, in order: (name, size, source system, its output port);
# the source "state" is the vehicle's state port itself. The "obstacle" size
# is the default count's (`log_layout` for a sensor's own).
LOG_LAYOUT: list[tuple[str, int, str, str]] = [
    ("state", STATE_SIZE, "state", "state"),
    ("obstacle", OBSTACLE_SIGNAL_SIZE, "sensor", "obstacle"),
    ("obstacle_force_terms", 6, "navigator", "obstacle_force_terms"),
    ("goal_force_terms", 9, "selector", "goal_force_terms"),
    ("navigation_force", 3, "selector", "navigation_force"),
    ("mode", 1, "selector", "mode"),
    ("attitude_setpoint", 4, "attitude_pd", "attitude_setpoint"),
    ("propeller_force", ROTORS, "mixer", "propeller_force"),
    ("saturation", 1, "mixer", "saturation"),
]


def log_layout(readings: int = OBSTACLE_COUNT) -> list[tuple[str, int, str, str]]:
    """LOG_LAYOUT for a sensor of `readings` readings."""
    return [
        (name, signal_size(readings) if name == "obstacle" else size, system, port)
        for name, size, system, port in LOG_LAYOUT
    ]


def readings_of(sensor) -> int:
    """How many readings the system `sensor`'s "obstacle" output holds."""
    return sensor.GetOutputPort("obstacle").size() // READING_SIZE


def log_slices(readings: int = OBSTACLE_COUNT) -> dict[str, slice]:
    """Each logged signal's rows of the logger's data (`readings`: the
    sensor's count)."""
    return slices((name, size) for name, size, _, _ in log_layout(readings))


@dataclass
class CameraMount:
    """Where cameras ride: the vehicle's body frame in SceneGraph and the
    FramePoseVector output port that poses it (a MultibodyPlant's
    geometry pose port, or a `VehicleGeometry`'s)."""

    frame_id: FrameId
    pose_port: OutputPort


def own_geometry(scene_graph: SceneGraph, ignore) -> frozenset:
    """The GeometryIds of `ignore` (GeometryIds, and FrameIds standing for
    every proximity geometry on the frame)."""
    inspector = scene_graph.model_inspector()
    ids = set()
    for item in ignore:
        if isinstance(item, FrameId):
            ids.update(inspector.GetGeometries(item, Role.kProximity))
        elif isinstance(item, GeometryId):
            ids.add(item)
        else:
            raise TypeError(f"ignore: {item!r} is neither a GeometryId nor a FrameId")
    return frozenset(ids)


def add_sensor(
    builder: DiagramBuilder,
    sensor: Sensor,
    scene_graph: SceneGraph,
    state_port: OutputPort,
    *,
    vehicle: "str | Vehicle" = "drake_default",
    other_vehicles: int = 0,
    moving: bool = False,
    ignore=(),
    mount: CameraMount | None = None,
    map_points: np.ndarray | None = None,
) -> LeafSystem:
    """Adds the sensor of the configuration `sensor` (a `SphereSensor` or a
    camera rig, `config.scenario`), named "sensor", reading `scene_graph`
    from the vehicle's state `state_port`; returns the system whose output
    port "obstacle" carries readings [r_o, seen] (`maths.layout`).

    Every proximity geometry of `scene_graph` is an obstacle, but `ignore`
    (GeometryIds or FrameIds: the vehicle's own shapes). `moving`: whether
    any of them moves (turns off the sphere sensor's memo). Cameras ride on
    `mount`; without one a `VehicleGeometry` "vehicle_geometry" is added,
    posed from `state_port`, whose shapes no camera sees; where the
    vehicle has shapes of its own (`ignore`), the cameras' near plane is
    put beyond its collision radius. Their "state" input is left for
    `add_controller` to feed with the state estimate.

    `other_vehicles`: how many other vehicles of a fleet the diagram sees
    through its exported input "other_vehicles" (`systems.exchange`): a
    sphere sensor's readings go through `OtherVehicleReadings`, which is
    then the system returned; cameras see `OtherVehicleSpheres`, their near
    plane beyond the collision radius, as a real depth camera's minimum
    range.

    `map_points` (n, 3): a point-cloud map (`Scenario.map_points`), read
    by a `PointMapSensor` instead of `scene_graph`'s geometry."""
    vehicle = as_vehicle(vehicle)
    mapped = map_points is not None and len(map_points) > 0
    if mapped and not isinstance(sensor, SphereSensor):
        raise TypeError(f"sensor = {sensor!r}: a point-cloud map has no surfaces")
    if isinstance(sensor, Cameras):
        if mount is None:
            mount = _drawn_vehicle(builder, scene_graph, state_port, vehicle)
        if other_vehicles:
            _add_other_vehicles(builder, scene_graph, other_vehicles, vehicle)
        return add_depth_cameras(
            builder,
            sensor,
            scene_graph,
            mount.frame_id,
            mount.pose_port,
            # Beyond the own sphere where the vehicle has shapes in SceneGraph.
            clear_of=vehicle.collision_radius if other_vehicles or ignore else 0.0,
        )
    if not isinstance(sensor, SphereSensor):
        raise TypeError(f"sensor = {sensor!r}: not a SphereSensor or camera rig")
    name = "scene_sensor" if other_vehicles else "sensor"
    if mapped:
        system = builder.AddNamedSystem(
            name, PointMapSensor(map_points, sensor.radius, sensor.readings)
        )
    else:
        system = builder.AddNamedSystem(
            name,
            SphereSensorSystem(
                sensor.radius,
                moving=moving,
                ignore=own_geometry(scene_graph, ignore),
                readings=sensor.readings,
            ),
        )
        builder.Connect(
            scene_graph.get_query_output_port(), system.GetInputPort("query")
        )
    builder.Connect(state_port, system.GetInputPort("state"))
    if not other_vehicles:
        return system
    return _fleet_readings(builder, system, state_port, other_vehicles, vehicle, sensor)


def _drawn_vehicle(
    builder: DiagramBuilder,
    scene_graph: SceneGraph,
    state_port: OutputPort,
    vehicle: Vehicle,
) -> CameraMount:
    """The mount of cameras on a vehicle that has no shapes in SceneGraph:
    a `VehicleGeometry` "vehicle_geometry" posed from `state_port`."""
    geometry = builder.AddNamedSystem(
        "vehicle_geometry",
        VehicleGeometry(scene_graph, vehicle.arm_length, vehicle.rotor_radius),
    )
    builder.Connect(state_port, geometry.get_input_port(0))
    builder.Connect(
        geometry.get_output_port(0),
        scene_graph.get_source_pose_port(geometry.source_id),
    )
    return CameraMount(geometry.frame_id, geometry.get_output_port(0))


def _add_other_vehicles(
    builder: DiagramBuilder, scene_graph: SceneGraph, count: int, vehicle: Vehicle
) -> None:
    """The other vehicles of a fleet as spheres in SceneGraph, posed from
    the exported input "other_vehicles", for cameras to see."""
    spheres = builder.AddNamedSystem(
        "other_vehicles",
        OtherVehicleSpheres(scene_graph, count, vehicle.collision_radius),
    )
    builder.Connect(
        spheres.get_output_port(),
        scene_graph.get_source_pose_port(spheres.source_id),
    )
    builder.ExportInput(spheres.get_input_port(), "other_vehicles")


def _fleet_readings(
    builder: DiagramBuilder,
    scene_sensor: LeafSystem,
    state_port: OutputPort,
    other_vehicles: int,
    vehicle: Vehicle,
    sensor: SphereSensor,
) -> OtherVehicleReadings:
    """The sphere sensor's readings with the other vehicles' spheres of the
    exported input "other_vehicles" (`systems.exchange`)."""
    readings = builder.AddNamedSystem(
        "sensor",
        OtherVehicleReadings(
            other_vehicles, vehicle.collision_radius, sensor.radius, sensor.readings
        ),
    )
    builder.Connect(
        scene_sensor.GetOutputPort("obstacle"), readings.GetInputPort("obstacle")
    )
    builder.Connect(state_port, readings.GetInputPort("state"))
    builder.ExportInput(readings.GetInputPort("other_vehicles"), "other_vehicles")
    return readings


def named_apart(builder: DiagramBuilder, before: set[int]) -> None:
    """The systems added to `builder` since `before` (the ids of those it
    held) renamed "vehicle_K/NAME", K = 1, 2, ..., where one of them holds
    a name already taken (a second vehicle's chain): Drake's Build()
    refuses two systems of one name, and would stop the process. The first
    vehicle's keep their plain names."""
    taken = {s.get_name() for s in builder.GetSystems() if id(s) in before}
    added = [s for s in builder.GetSystems() if id(s) not in before]
    if not any(s.get_name() in taken for s in added):
        return
    k = 1
    while any(name.startswith(f"vehicle_{k}/") for name in taken):
        k += 1
    for system in added:
        system.set_name(f"vehicle_{k}/{system.get_name()}")


@dataclass
class Controller:
    """The systems `add_controller` adds, and the port of the state
    estimate they read."""

    navigator: System  # a LeafSystem, or the relative navigator's Diagram
    selector: LeafSystem  # the goal attraction (eq 16–21's for MFI)
    attitude_pd: AttitudePD
    mixer: RotorMixer
    estimate: OutputPort


def add_controller(
    builder: DiagramBuilder,
    config: NavigationConfig,
    state_port: OutputPort,
    sensor: System,
    rotor_input: InputPort,
    *,
    method: "str | Callable | Method | None" = None,
) -> Controller:
    """Adds the method's navigator "navigator" and goal attraction
    "selector", eq 25's "attitude_pd" and the "mixer", and closes the loop
    from the vehicle's state `state_port` to the 4 rotor forces
    `rotor_input`, through the config's faults. `config` gives the goal,
    vehicle, method, gains, sensor and what the navigator knows of the
    scene (`NavigationConfig`); `method` (a name, a user's field or a
    `Method`) replaces its `method`. `sensor`: a system with the output
    "obstacle" (`add_sensor`'s, or the user's own); the navigator also
    reads its "obstacle_velocity", "vehicle_readings" and "scene" (MFI's
    escape memory in a fleet) where it has them, and a "state" input of it
    left unconnected gets the state estimate (a camera places its images
    with it, as on board). Raises ScenarioError naming a bad field of
    `config`."""
    check_navigation(config, "add_controller")
    method = resolve_method(config.method if method is None else method)
    vehicle = as_vehicle(config.vehicle)
    navigator = builder.AddNamedSystem(
        "navigator", navigator_of(config, method, vehicle)
    )
    selector = builder.AddNamedSystem(
        "selector", method.goal_attraction(config, vehicle)
    )
    attitude = builder.AddNamedSystem(
        "attitude_pd", AttitudePD(vehicle, config.navigator)
    )
    mixer = builder.AddNamedSystem("mixer", RotorMixer(vehicle))
    for name in ("obstacle_velocity", "vehicle_readings", "scene"):
        if navigator.HasInputPort(name):
            builder.Connect(sensor.GetOutputPort(name), navigator.GetInputPort(name))
    estimate = connect_controller(
        builder,
        state_port,
        add_sensor_faults(builder, config.faults, sensor.GetOutputPort("obstacle")),
        navigator,
        selector,
        attitude,
        mixer,
        rotor_input,
        config.faults,
    )
    if sensor.HasInputPort("state"):
        state = sensor.GetInputPort("state")
        if not builder.IsConnectedOrExported(state):
            builder.Connect(estimate, state)
    return Controller(navigator, selector, attitude, mixer, estimate)


def connect_controller(
    builder: DiagramBuilder,
    state_port: OutputPort,
    obstacle_port: OutputPort,
    navigator,
    selector,
    attitude,
    mixer,
    rotor_input: InputPort,
    faults: Faults | None = None,
) -> OutputPort:
    """Closes the loop: state → navigator (its "obstacle" input from
    `obstacle_port`, a sensor's or, in `flight.analysis_diagram`, a constant
    source's) → selector → attitude PD → mixer → `rotor_input`, through the
    state-estimate error and rotor faults of `faults` when they are on.
    Returns the port of the state estimate the controller reads."""
    faults = faults or Faults()
    state = add_state_estimate(builder, faults, state_port)
    builder.Connect(state, navigator.GetInputPort("state"))
    builder.Connect(obstacle_port, navigator.GetInputPort("obstacle"))
    builder.Connect(state, selector.GetInputPort("state"))
    builder.Connect(
        navigator.GetOutputPort("obstacle_force"),
        selector.GetInputPort("obstacle_force"),
    )
    if navigator.HasInputPort("goal_mode"):  # the escape rule's (eq 21's mode)
        builder.Connect(
            selector.GetOutputPort("mode"), navigator.GetInputPort("goal_mode")
        )
    builder.Connect(
        selector.GetOutputPort("navigation_force"),
        attitude.GetInputPort("navigation_force"),
    )
    builder.Connect(state, attitude.GetInputPort("state"))
    builder.Connect(
        attitude.GetOutputPort("thrust_torque"), mixer.GetInputPort("thrust_torque")
    )
    rotors = add_rotor_faults(
        builder,
        faults,
        mixer.vehicle.hover_command,
        mixer.GetOutputPort("propeller_force"),
    )
    builder.Connect(rotors, rotor_input)
    return state


def add_logger(
    builder: DiagramBuilder,
    state_port: OutputPort,
    sensor,
    controller: Controller,
) -> VectorLogSink:
    """Adds the Multiplexer "log_mux" of every signal of LOG_LAYOUT (the
    "obstacle" as long as the sensor's) and the VectorLogSink "logger" that
    records it at every integrator step."""
    layout = log_layout(readings_of(sensor))
    mux = builder.AddNamedSystem(
        "log_mux", Multiplexer([size for _, size, _, _ in layout])
    )
    systems = {
        "sensor": sensor,
        "navigator": controller.navigator,
        "selector": controller.selector,
        "attitude_pd": controller.attitude_pd,
        "mixer": controller.mixer,
    }
    for i, (_, _, system_name, port_name) in enumerate(layout):
        port = (
            state_port
            if system_name == "state"
            else systems[system_name].GetOutputPort(port_name)
        )
        builder.Connect(port, mux.get_input_port(i))
    # publish_period 0: the sink records once per integrator step.
    logger = LogVectorOutput(mux.get_output_port(0), builder, publish_period=0.0)
    logger.set_name("logger")
    return logger


def navigator_of(config: NavigationConfig, method: Method, vehicle: Vehicle) -> System:
    """The method's navigator; in a dynamic scene (moving obstacles or
    other vehicles), with the velocity relative to each obstacle
    (`systems.relative`) when the method's force is a sum over readings
    (MFI and the baselines; a user field gets the vehicle's own velocity,
    as its contract says)."""
    navigator = method.navigator(config, vehicle)
    estimate = config.relative_velocity
    dynamic = config.other_vehicles > 0 or config.moving_obstacles
    if dynamic and estimate.enabled and isinstance(navigator, ObstacleNavigator):
        # The rule of the road needs to know which readings are vehicles:
        # the sphere sensor's `OtherVehicleReadings` says, a camera cannot.
        sensor = config.sensor
        keep_right = 0.0
        if config.other_vehicles and isinstance(sensor, SphereSensor):
            keep_right = estimate.keep_right
        if knows_velocities(config):
            return RelativeNavigator(
                navigator,
                estimate.own_pace,
                PACE_BLEND_SPEED,
                keep_right,
                sensor.readings,
            )
        # A camera's readings change once a frame: sampled at its frame rate.
        rate = sensor.rate_hz if isinstance(sensor, Cameras) else estimate.rate_hz
        navigator = relative_navigator(
            lambda: method.navigator(config, vehicle),
            estimate,
            rate,
            keep_right,
            sensor.readings,
        )
    return navigator


def knows_velocities(config: NavigationConfig) -> bool:
    """Whether every moving thing the sensor reads comes with its velocity:
    other vehicles seen through `OtherVehicleReadings`, no moving obstacle.
    The relative navigator then reads those velocities and needs no
    estimate from the readings."""
    return (
        isinstance(config.sensor, SphereSensor)
        and config.other_vehicles > 0
        and not config.moving_obstacles
    )
