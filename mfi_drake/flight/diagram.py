"""`build_diagram`: one scenario and one method, one Drake diagram.

    SceneGraph ──query──▶ sensor ──obstacle──▶ navigator ──F_o──▶ selector
        ▲                   ▲                      ▲                 │ F_n
        │ pose              │ state                │ state           ▼
    VehicleGeometry ◀── QuadrotorPlant ◀── RotorMixer ◀── AttitudePD ◀┘

VehicleGeometry is there only where cameras ride on the vehicle
(`needs_geometry`).
Every signal worth reading afterwards goes through one Multiplexer into a
VectorLogSink that records at every integrator step. The scenario's faults
(`faults`) are inserted only when turned on; the log keeps the true state.

A dynamic scene (docs/dynamic.md) adds the `ObstacleMotion` source that
poses the moving obstacles and a navigator that uses the velocity relative
to each obstacle (`systems.relative`). With `other_vehicles` the diagram is
still one vehicle's, the scenario's own: the others come in through the
exported input "other_vehicles", the last message of the fleet's exchange
(`systems.exchange`), as spheres added to the sphere sensor's readings
(`OtherVehicleReadings`, which also gives their velocities to the relative
navigator where nothing else moves) or posed in SceneGraph for cameras
(`OtherVehicleSpheres`). A fleet flies one such diagram per vehicle
(`vehicle_scenarios`, `simulation.fly_fleet`).
"""

from dataclasses import dataclass, replace

from pydrake.examples import QuadrotorPlant
from pydrake.geometry import SceneGraph
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, Multiplexer, VectorLogSink

from mfi_drake.config.dynamic import OtherVehicle
from mfi_drake.config.faults import Faults
from mfi_drake.config.scenario import Cameras, Scenario, SphereSensor
from mfi_drake.config.vehicles import VEHICLES, Vehicle
from mfi_drake.flight.methods import Method, resolve_method
from mfi_drake.maths.layout import OBSTACLE_SIGNAL_SIZE, ROTORS, STATE_SIZE, slices
from mfi_drake.maths.motion import PACE_BLEND_SPEED
from mfi_drake.systems.camera import add_depth_cameras
from mfi_drake.systems.control import AttitudePD, RotorMixer
from mfi_drake.systems.exchange import OtherVehicleReadings, OtherVehicleSpheres
from mfi_drake.systems.faults import (
    add_rotor_faults,
    add_sensor_faults,
    add_state_estimate,
)
from mfi_drake.systems.motion import ObstacleMotion
from mfi_drake.systems.navigation import ObstacleNavigator
from mfi_drake.systems.relative import RelativeNavigator, relative_navigator
from mfi_drake.systems.sensors import SphereSensor as SphereSensorSystem
from mfi_drake.systems.sensors import VehicleGeometry
from mfi_drake.world.motion import is_dynamic, obstacles_move
from mfi_drake.world.obstacles import register_obstacles

# What the log holds, in order: (name, size, source system, its output port).
LOG_LAYOUT: list[tuple[str, int, str, str]] = [
    ("state", STATE_SIZE, "quadrotor", "state"),
    ("obstacle", OBSTACLE_SIGNAL_SIZE, "sensor", "obstacle"),
    ("obstacle_force_terms", 6, "navigator", "obstacle_force_terms"),
    ("goal_force_terms", 9, "selector", "goal_force_terms"),
    ("navigation_force", 3, "selector", "navigation_force"),
    ("mode", 1, "selector", "mode"),
    ("attitude_setpoint", 4, "attitude_pd", "attitude_setpoint"),
    ("propeller_force", ROTORS, "mixer", "propeller_force"),
    ("saturation", 1, "mixer", "saturation"),
]


@dataclass
class FlightDiagram:
    """The built diagram and the handles a simulation needs."""

    diagram: Diagram
    scenario: Scenario
    vehicle: Vehicle
    method: str  # its name in the registry, or a user field's MODULE:NAME
    plant: QuadrotorPlant
    scene_graph: SceneGraph
    logger: VectorLogSink
    sensor: object  # the system whose "obstacle" port the navigator reads

    def log_slices(self) -> dict[str, slice]:
        return slices((name, size) for name, size, _, _ in LOG_LAYOUT)


def make_plant(vehicle: Vehicle) -> QuadrotorPlant:
    return QuadrotorPlant(
        vehicle.mass,
        vehicle.arm_length,
        vehicle.inertia_matrix(),
        vehicle.kF,
        vehicle.kM,
    )


def add_sensor(
    builder: DiagramBuilder,
    scenario: Scenario,
    scene_graph: SceneGraph,
    plant: QuadrotorPlant,
    geometry: VehicleGeometry | None,
):
    """Adds the scenario's sensor, named "sensor", whose output port
    "obstacle" carries readings [r_o, seen] (see `maths.layout`). A camera
    rig's "state" input is left for `build_diagram` to connect. `geometry`:
    the vehicle in SceneGraph (`needs_geometry`), else None. With
    `other_vehicles` the diagram exports the input "other_vehicles"
    (`systems.exchange`): a sphere sensor's readings go through
    `OtherVehicleReadings`, which is then the system returned; cameras see
    `OtherVehicleSpheres`, their near plane beyond the collision radius, as
    a real depth camera's minimum range."""
    count = len(scenario.other_vehicles)
    radius = VEHICLES[scenario.vehicle].collision_radius
    if isinstance(scenario.sensor, Cameras):
        if count:
            spheres = builder.AddNamedSystem(
                "other_vehicles", OtherVehicleSpheres(scene_graph, count, radius)
            )
            builder.Connect(
                spheres.get_output_port(),
                scene_graph.get_source_pose_port(spheres.source_id),
            )
            builder.ExportInput(spheres.get_input_port(), "other_vehicles")
        return add_depth_cameras(
            builder,
            scenario.sensor,
            scene_graph,
            geometry,
            clear_of=radius if count else 0.0,
        )
    if not isinstance(scenario.sensor, SphereSensor):
        raise ValueError(f"sensor = {scenario.sensor!r}: not supported")
    sensor = builder.AddNamedSystem(
        "scene_sensor" if count else "sensor",
        SphereSensorSystem(scenario.sensor.radius, moving=obstacles_move(scenario)),
    )
    builder.Connect(scene_graph.get_query_output_port(), sensor.GetInputPort("query"))
    builder.Connect(plant.get_output_port(0), sensor.GetInputPort("state"))
    if not count:
        return sensor
    readings = builder.AddNamedSystem(
        "sensor", OtherVehicleReadings(count, radius, scenario.sensor.radius)
    )
    builder.Connect(sensor.GetOutputPort("obstacle"), readings.GetInputPort("obstacle"))
    builder.Connect(plant.get_output_port(0), readings.GetInputPort("state"))
    builder.ExportInput(readings.GetInputPort("other_vehicles"), "other_vehicles")
    return readings


def connect_controller(
    builder: DiagramBuilder,
    plant: QuadrotorPlant,
    obstacle_port,
    navigator,
    selector,
    attitude,
    mixer,
    faults: Faults | None = None,
):
    """Closes the loop: plant state → navigator (its "obstacle" input from
    `obstacle_port`, a sensor's or, in `flight.analysis_diagram`, a constant source's) →
    selector → attitude PD → mixer → plant, through the state-estimate error
    and rotor faults of `faults` when they are on. Returns the port of the
    state estimate the controller reads."""
    faults = faults or Faults()
    state = add_state_estimate(builder, faults, plant.get_output_port(0))
    builder.Connect(state, navigator.GetInputPort("state"))
    builder.Connect(obstacle_port, navigator.GetInputPort("obstacle"))
    builder.Connect(state, selector.GetInputPort("state"))
    builder.Connect(
        navigator.GetOutputPort("obstacle_force"),
        selector.GetInputPort("obstacle_force"),
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
    builder.Connect(rotors, plant.get_input_port(0))
    return state


def build_diagram(scenario: Scenario, method: "str | Method" = "mfi") -> FlightDiagram:
    """Builds the closed loop of `scenario`'s own vehicle flown by `method`
    (a registry name, a user field's MODULE:NAME or callable, see
    `methods`). With `other_vehicles` they are seen where the diagram's
    input "other_vehicles" puts them (`add_sensor`)."""
    method = resolve_method(method)
    builder = DiagramBuilder()

    scene_graph = builder.AddNamedSystem("scene_graph", SceneGraph())
    frames = register_obstacles(scene_graph, scenario)
    if frames.frames:
        motion = builder.AddNamedSystem("obstacle_motion", ObstacleMotion(frames))
        builder.Connect(
            motion.get_output_port(), scene_graph.get_source_pose_port(frames.source_id)
        )
    vehicle = VEHICLES[scenario.vehicle]
    plant, sensor, logger = add_vehicle(builder, scene_graph, scenario, method)
    if sensor.HasOutputPort("frames_rendered"):  # a camera counts its frames
        builder.ExportOutput(sensor.GetOutputPort("frames_rendered"), "frames_rendered")

    diagram = builder.Build()
    diagram.set_name(f"mfi_drake[{scenario.name}, {method.name}]")
    return FlightDiagram(
        diagram=diagram,
        scenario=scenario,
        vehicle=vehicle,
        method=method.name,
        plant=plant,
        scene_graph=scene_graph,
        logger=logger,
        sensor=sensor,
    )


def vehicle_scenarios(scenario: Scenario) -> list[Scenario]:
    """One scenario per vehicle of the fleet, the scenario's own first: the
    vehicle's start and goal, and every other vehicle in `other_vehicles`,
    in the fleet's order (`systems.exchange.others_of`)."""
    ends = [(scenario.start, scenario.goal)]
    ends += [(o.start, o.goal) for o in scenario.other_vehicles]
    return [
        replace(
            scenario,
            start=list(start),
            goal=list(goal),
            other_vehicles=[
                OtherVehicle(list(s), list(g))
                for j, (s, g) in enumerate(ends)
                if j != k
            ],
        )
        for k, (start, goal) in enumerate(ends)
    ]


def navigator_of(scenario: Scenario, method: Method, vehicle: Vehicle):
    """The method's navigator; in a dynamic scene, with the velocity relative
    to each obstacle (`systems.relative`) when the method's force is a sum
    over readings (MFI and the baselines; a user field gets the vehicle's
    own velocity, as its contract says)."""
    navigator = method.navigator(scenario, vehicle)
    estimate = scenario.relative_velocity
    if (
        is_dynamic(scenario)
        and estimate.enabled
        and isinstance(navigator, ObstacleNavigator)
    ):
        # The rule of the road needs to know which readings are vehicles:
        # the sphere sensor's `OtherVehicleReadings` says, a camera cannot.
        sensor = scenario.sensor
        keep_right = 0.0
        if scenario.other_vehicles and isinstance(sensor, SphereSensor):
            keep_right = estimate.keep_right
        if knows_velocities(scenario):
            return RelativeNavigator(
                navigator, estimate.own_pace, PACE_BLEND_SPEED, keep_right
            )
        # A camera's readings change once a frame: sampled at its frame rate.
        rate = sensor.rate_hz if isinstance(sensor, Cameras) else estimate.rate_hz
        navigator = relative_navigator(
            lambda: method.navigator(scenario, vehicle), estimate, rate, keep_right
        )
    return navigator


def knows_velocities(scenario: Scenario) -> bool:
    """Whether every moving thing the sensor reads comes with its velocity:
    other vehicles seen through `OtherVehicleReadings`, no moving obstacle.
    The relative navigator then reads those velocities and needs no
    estimate from the readings."""
    return (
        isinstance(scenario.sensor, SphereSensor)
        and bool(scenario.other_vehicles)
        and not obstacles_move(scenario)
    )


def needs_geometry(scenario: Scenario) -> bool:
    """Whether the flight needs its vehicle in SceneGraph: cameras ride on
    the body frame. A sphere sensor reads its position from the state and
    nothing in the flight draws it (animations replay the log; other
    vehicles see it through the exchange), so it flies without: a Python
    pose system less, evaluated at every state. (Drake's C++
    QuadrotorGeometry would download its mesh package at build time.)"""
    return isinstance(scenario.sensor, Cameras)


def add_vehicle(
    builder: DiagramBuilder,
    scene_graph: SceneGraph,
    scenario: Scenario,
    method: Method,
) -> tuple[QuadrotorPlant, object, VectorLogSink]:
    """Adds the vehicle's closed loop, flying `scenario`'s start to its goal;
    (its plant, its sensor, its logger)."""
    vehicle = VEHICLES[scenario.vehicle]
    params = scenario.navigator
    plant = builder.AddNamedSystem("quadrotor", make_plant(vehicle))
    geometry = None
    if needs_geometry(scenario):
        geometry = builder.AddNamedSystem(
            "vehicle_geometry",
            VehicleGeometry(scene_graph, vehicle.arm_length, vehicle.rotor_radius),
        )
        builder.Connect(plant.get_output_port(0), geometry.get_input_port(0))
        builder.Connect(
            geometry.get_output_port(0),
            scene_graph.get_source_pose_port(geometry.source_id),
        )

    sensor = add_sensor(builder, scenario, scene_graph, plant, geometry)

    navigator = builder.AddNamedSystem(
        "navigator", navigator_of(scenario, method, vehicle)
    )
    selector = builder.AddNamedSystem(
        "selector", method.goal_attraction(scenario, vehicle)
    )
    attitude = builder.AddNamedSystem("attitude_pd", AttitudePD(vehicle, params))
    mixer = builder.AddNamedSystem("mixer", RotorMixer(vehicle))
    # `knows_velocities`; the rule of the road among vehicles.
    for name in ("obstacle_velocity", "vehicle_readings"):
        if navigator.HasInputPort(name):
            builder.Connect(sensor.GetOutputPort(name), navigator.GetInputPort(name))
    estimate = connect_controller(
        builder,
        plant,
        add_sensor_faults(builder, scenario.faults, sensor.GetOutputPort("obstacle")),
        navigator,
        selector,
        attitude,
        mixer,
        scenario.faults,
    )
    if isinstance(scenario.sensor, Cameras):
        # The cameras' memory is placed with the estimate, as on board.
        builder.Connect(estimate, sensor.GetInputPort("state"))

    mux = builder.AddNamedSystem(
        "log_mux", Multiplexer([size for _, size, _, _ in LOG_LAYOUT])
    )
    systems = {
        "quadrotor": plant,
        "sensor": sensor,
        "navigator": navigator,
        "selector": selector,
        "attitude_pd": attitude,
        "mixer": mixer,
    }
    for i, (_, _, system_name, port_name) in enumerate(LOG_LAYOUT):
        source = systems[system_name]
        port = (
            source.get_output_port(0)
            if source is plant
            else source.GetOutputPort(port_name)
        )
        builder.Connect(port, mux.get_input_port(i))
    # publish_period 0: the sink records once per integrator step.
    logger = LogVectorOutput(mux.get_output_port(0), builder, publish_period=0.0)
    logger.set_name("logger")
    return plant, sensor, logger
