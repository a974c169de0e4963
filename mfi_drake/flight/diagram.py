"""`build_diagram`: one scenario and one method, one Drake diagram.

    SceneGraph ──query──▶ sensor ──obstacle──▶ navigator ──F_o──▶ selector
        ▲                   ▲                      ▲                 │ F_n
        │ pose              │ state                │ state           ▼
    VehicleGeometry ◀── QuadrotorPlant ◀── RotorMixer ◀── AttitudePD ◀┘

VehicleGeometry is there only where something reads the vehicle in
SceneGraph: cameras, or other vehicles' sensors (`needs_geometry`).
Every signal worth reading afterwards goes through one Multiplexer into a
VectorLogSink that records at every integrator step. The scenario's faults
(`faults`) are inserted only when turned on; the log keeps the true state.

A dynamic scene (docs/dynamic.md) adds the `ObstacleMotion` source that
poses the moving obstacles, a navigator that uses the velocity relative to
each obstacle (`systems.relative`), and each of the `other_vehicles` as a
closed loop of its own, the same systems with names ending "_k" (k = 1, 2,
…) and a logger of its own.
"""

from dataclasses import dataclass, field, replace

from pydrake.examples import QuadrotorPlant
from pydrake.geometry import SceneGraph
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, Multiplexer, VectorLogSink

from mfi_drake.config.faults import Faults
from mfi_drake.config.scenario import Cameras, Scenario, SphereSensor
from mfi_drake.config.vehicles import VEHICLES, Vehicle
from mfi_drake.flight.methods import Method, resolve_method
from mfi_drake.maths.layout import OBSTACLE_SIGNAL_SIZE, ROTORS, STATE_SIZE
from mfi_drake.systems.camera import add_depth_cameras
from mfi_drake.systems.control import AttitudePD, RotorMixer
from mfi_drake.systems.faults import (
    add_rotor_faults,
    add_sensor_faults,
    add_state_estimate,
)
from mfi_drake.systems.motion import ObstacleMotion
from mfi_drake.systems.navigation import ObstacleNavigator
from mfi_drake.systems.relative import relative_navigator
from mfi_drake.systems.sensors import SphereSensor as SphereSensorSystem
from mfi_drake.systems.sensors import VehicleGeometry
from mfi_drake.world.motion import is_dynamic
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
class VehicleLoop:
    """One vehicle's closed loop in a flight's diagram."""

    scenario: Scenario  # the flight's, with this vehicle's start and goal
    plant: QuadrotorPlant
    sensor: object  # the system whose "obstacle" port the navigator reads
    logger: VectorLogSink


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
    others: list[VehicleLoop] = field(default_factory=list)  # other_vehicles

    def log_slices(self) -> dict[str, slice]:
        slices, start = {}, 0
        for name, size, _, _ in LOG_LAYOUT:
            slices[name] = slice(start, start + size)
            start += size
        return slices


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
    suffix: str = "",
):
    """Adds the scenario's sensor, named "sensor" + suffix, whose output port
    "obstacle" carries readings [r_o, seen] (see `maths.layout`). A camera
    rig's "state" input is left for `build_diagram` to connect. A sphere
    sensor does not see its own vehicle's collision sphere. `geometry`: the
    vehicle in SceneGraph (`needs_geometry`), else None."""
    if isinstance(scenario.sensor, Cameras):
        return add_depth_cameras(
            builder,
            scenario.sensor,
            scene_graph,
            geometry,
            suffix,
            geometry.sphere_radius or 0.0,
        )
    if not isinstance(scenario.sensor, SphereSensor):
        raise ValueError(f"sensor = {scenario.sensor!r}: not supported")
    sensor = builder.AddNamedSystem(
        f"sensor{suffix}",
        SphereSensorSystem(
            scenario.sensor.radius,
            ignored={geometry.sphere_id} - {None} if geometry else set(),
            moving=is_dynamic(scenario),
        ),
    )
    builder.Connect(scene_graph.get_query_output_port(), sensor.GetInputPort("query"))
    builder.Connect(plant.get_output_port(0), sensor.GetInputPort("state"))
    return sensor


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
    """Builds the closed loop of `scenario` flown by `method` (a registry
    name, a user field's MODULE:NAME or callable, see `methods`), with one
    loop per vehicle when the scenario has `other_vehicles`."""
    method = resolve_method(method)
    builder = DiagramBuilder()

    scene_graph = builder.AddNamedSystem("scene_graph", SceneGraph())
    frames = register_obstacles(scene_graph, scenario)
    if frames.frames:
        motion = builder.AddNamedSystem("obstacle_motion", ObstacleMotion(frames))
        builder.Connect(
            motion.get_output_port(), scene_graph.get_source_pose_port(frames.source_id)
        )
    loops = [
        add_vehicle(builder, scene_graph, flown, method, suffix)
        for suffix, flown in vehicle_scenarios(scenario)
    ]
    sensor = loops[0].sensor
    if sensor.HasOutputPort("frames_rendered"):  # a camera counts its frames
        builder.ExportOutput(sensor.GetOutputPort("frames_rendered"), "frames_rendered")

    diagram = builder.Build()
    diagram.set_name(f"mfi_drake[{scenario.name}, {method.name}]")
    return FlightDiagram(
        diagram=diagram,
        scenario=scenario,
        vehicle=VEHICLES[scenario.vehicle],
        method=method.name,
        plant=loops[0].plant,
        scene_graph=scene_graph,
        logger=loops[0].logger,
        sensor=sensor,
        others=loops[1:],
    )


def vehicle_scenarios(scenario: Scenario) -> list[tuple[str, Scenario]]:
    """(name suffix, the scenario with its start and goal) of each vehicle:
    the scenario's own first ("" : its systems keep their plain names), then
    each of `other_vehicles` ("_1", "_2", …)."""
    return [("", scenario)] + [
        (f"_{k}", replace(scenario, start=list(o.start), goal=list(o.goal)))
        for k, o in enumerate(scenario.other_vehicles, start=1)
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
        # A camera's readings change once a frame: sampled at its frame rate.
        sensor = scenario.sensor
        rate = sensor.rate_hz if isinstance(sensor, Cameras) else estimate.rate_hz
        navigator = relative_navigator(
            lambda: method.navigator(scenario, vehicle), estimate, rate
        )
    return navigator


def needs_geometry(scenario: Scenario) -> bool:
    """Whether the flight needs its vehicles in SceneGraph: cameras ride on
    the body frame, and among several vehicles each one's collision sphere
    is seen by the others. A lone vehicle's sphere sensor reads its position
    from the state and nothing in the flight draws it (animations replay
    the log), so it flies without: a Python pose system less, evaluated at
    every state. (Drake's C++ QuadrotorGeometry would download its mesh
    package at build time.)"""
    return isinstance(scenario.sensor, Cameras) or bool(scenario.other_vehicles)


def add_vehicle(
    builder: DiagramBuilder,
    scene_graph: SceneGraph,
    scenario: Scenario,
    method: Method,
    suffix: str = "",
) -> VehicleLoop:
    """Adds one vehicle's closed loop, flying `scenario`'s start to its goal;
    its systems' names end in `suffix`. Among several vehicles, each carries
    its collision sphere for the others' sensors."""
    vehicle = VEHICLES[scenario.vehicle]
    params = scenario.navigator
    plant = builder.AddNamedSystem(f"quadrotor{suffix}", make_plant(vehicle))
    geometry = None
    if needs_geometry(scenario):
        geometry = builder.AddNamedSystem(
            f"vehicle_geometry{suffix}",
            VehicleGeometry(
                scene_graph,
                vehicle.arm_length,
                vehicle.rotor_radius,
                sphere_radius=(
                    vehicle.collision_radius if scenario.other_vehicles else None
                ),
                name=f"vehicle{suffix}",
                perceived=isinstance(scenario.sensor, Cameras),
            ),
        )
        builder.Connect(plant.get_output_port(0), geometry.get_input_port(0))
        builder.Connect(
            geometry.get_output_port(0),
            scene_graph.get_source_pose_port(geometry.source_id),
        )

    sensor = add_sensor(builder, scenario, scene_graph, plant, geometry, suffix)

    navigator = builder.AddNamedSystem(
        f"navigator{suffix}", navigator_of(scenario, method, vehicle)
    )
    selector = builder.AddNamedSystem(
        f"selector{suffix}", method.goal_attraction(scenario, vehicle)
    )
    attitude = builder.AddNamedSystem(
        f"attitude_pd{suffix}", AttitudePD(vehicle, params)
    )
    mixer = builder.AddNamedSystem(f"mixer{suffix}", RotorMixer(vehicle))
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
        f"log_mux{suffix}", Multiplexer([size for _, size, _, _ in LOG_LAYOUT])
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
    logger.set_name(f"logger{suffix}")
    return VehicleLoop(scenario, plant, sensor, logger)
