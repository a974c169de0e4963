"""`build_diagram`: one scenario and one method, one Drake diagram.

    SceneGraph ──query──▶ sensor ──obstacle──▶ navigator ──F_o──▶ selector
        ▲                   ▲                      ▲                 │ F_n
        │ pose              │ state                │ state           ▼
    VehicleGeometry ◀── QuadrotorPlant ◀── RotorMixer ◀── AttitudePD ◀┘

It is a user's diagram like any other: a SceneGraph with the scenario's
obstacles, a QuadrotorPlant, and the chain of the public builder API
(`flight.builder.add_navigation` given the scenario's `navigation_config`).
VehicleGeometry is there only where cameras ride on the vehicle.
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
(`vehicle_scenarios`, `fleet_exchange.fly_fleet`).
"""

from dataclasses import dataclass, replace

import numpy as np
from pydrake.examples import QuadrotorPlant
from pydrake.geometry import SceneGraph
from pydrake.systems.framework import Diagram, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import VectorLogSink

from mfi_drake.config.dynamic import OtherVehicle
from mfi_drake.config.navigation import navigation_config
from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicles import Vehicle, as_vehicle
from mfi_drake.flight.builder import NavigationHandles, add_navigation
from mfi_drake.flight.chain import LOG_LAYOUT, log_slices
from mfi_drake.flight.methods import Method, resolve_method
from mfi_drake.systems.motion import ObstacleMotion
from mfi_drake.world.motion import ObstacleFrames
from mfi_drake.world.obstacles import register_obstacles

# LOG_LAYOUT: the log of every FlightDiagram, named here for its readers.
__all__ = [
    "LOG_LAYOUT",
    "FlightDiagram",
    "add_obstacles",
    "build_diagram",
    "make_plant",
    "vehicle_scenarios",
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
    sensor: LeafSystem  # the system whose "obstacle" port the navigator reads
    handles: NavigationHandles

    def log_slices(self) -> dict[str, slice]:
        return log_slices(self.scenario.sensor.readings)


def make_plant(vehicle: Vehicle) -> QuadrotorPlant:
    return QuadrotorPlant(
        vehicle.mass,
        vehicle.arm_length,
        vehicle.inertia_matrix(),
        vehicle.kF,
        vehicle.kM,
    )


def build_diagram(scenario: Scenario, method: "str | Method" = "mfi") -> FlightDiagram:
    """Builds the closed loop of `scenario`'s own vehicle flown by `method`
    (a registry name, a user field's MODULE:NAME or callable, see
    `methods`). With `other_vehicles` they are seen where the diagram's
    input "other_vehicles" puts them (`chain.add_sensor`)."""
    method = resolve_method(method)
    builder = DiagramBuilder()

    scene_graph = builder.AddNamedSystem("scene_graph", SceneGraph())
    add_obstacles(builder, scene_graph, scenario)
    vehicle = as_vehicle(scenario.vehicle)
    plant = builder.AddNamedSystem("quadrotor", make_plant(vehicle))
    # A loaded scenario's goals are checked with a margin (`world.validation`);
    # a diagram is still built at any goal, to evaluate its outputs there.
    handles = add_navigation(
        builder,
        plant,
        scene_graph,
        config=navigation_config(scenario),
        method=method,
        check_goal=False,
        map_points=np.asarray(scenario.map_points, dtype=float).reshape(-1, 3),
    )
    sensor = handles.sensor
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
        logger=handles.logger,
        sensor=sensor,
        handles=handles,
    )


def add_obstacles(
    builder: DiagramBuilder, scene_graph: SceneGraph, scenario: Scenario
) -> ObstacleFrames:
    """Registers `scenario`'s obstacles with `scene_graph` and, where some
    move, adds the "obstacle_motion" source that poses them; returns their
    frames (none: nothing moves)."""
    frames = register_obstacles(scene_graph, scenario)
    if frames.frames:
        motion = builder.AddNamedSystem("obstacle_motion", ObstacleMotion(frames))
        builder.Connect(
            motion.get_output_port(), scene_graph.get_source_pose_port(frames.source_id)
        )
    return frames


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
