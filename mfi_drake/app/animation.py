"""A Meshcat animation of flown flights, saved as one standalone HTML file.

The flights are replayed from their logs rather than recorded while they are
simulated: a visualiser in the simulated diagram would add publish events
that change the integrator's steps, and so the flight. Each flight gets a
small diagram (SceneGraph, the vehicle's shapes in its method's colour,
Drake's MeshcatVisualizer under the prefix of its method); setting the logged
state frame by frame and publishing records the animation. The obstacles are
drawn once, and each method's whole path as a line of its colour.
"""

import numpy as np
from matplotlib.colors import to_rgba
from pydrake.geometry import (
    Meshcat,
    MeshcatParams,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    Rgba,
    SceneGraph,
)
from pydrake.systems.framework import DiagramBuilder

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.files import write_text
from mfi_drake.flight.methods import appearance
from mfi_drake.flight.simulation import Flight
from mfi_drake.systems.sensors import VehicleGeometry
from mfi_drake.world.obstacles import register_obstacles

FRAMES_PER_SECOND = 32.0


def _rgba(method: str) -> Rgba:
    return Rgba(*to_rgba(appearance(method)[1]))


def _record(
    meshcat: Meshcat, scenario: Scenario, flight: Flight, with_obstacles: bool
) -> None:
    vehicle = VEHICLES[scenario.vehicle]
    builder = DiagramBuilder()
    scene_graph = builder.AddSystem(SceneGraph())
    if with_obstacles:
        register_obstacles(scene_graph, scenario)
    geometry = builder.AddSystem(
        VehicleGeometry(
            scene_graph, vehicle.arm_length, vehicle.rotor_radius, _rgba(flight.method)
        )
    )
    builder.Connect(
        geometry.get_output_port(0),
        scene_graph.get_source_pose_port(geometry.source_id),
    )
    visualizer = MeshcatVisualizer.AddToBuilder(
        builder, scene_graph, meshcat, MeshcatVisualizerParams(prefix=flight.method)
    )
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    state_port = geometry.get_input_port(0)
    geometry_context = geometry.GetMyMutableContextFromRoot(context)
    visualizer_context = visualizer.GetMyContextFromRoot(context)
    states = flight.log["state"]
    frame_times = np.arange(0.0, flight.times[-1], 1.0 / FRAMES_PER_SECOND)
    # The last logged sample at or before each frame time.
    samples = np.searchsorted(flight.times, frame_times, side="right") - 1
    for t, i in zip(frame_times, samples, strict=True):
        context.SetTime(t)
        state_port.FixValue(geometry_context, states[i])
        visualizer.ForcedPublish(visualizer_context)
    meshcat.SetLine(
        f"paths/{flight.method}",
        flight.positions.T.copy(),
        line_width=2.0,
        rgba=_rgba(flight.method),
    )


def write_animation(scenario: Scenario, flights: list[Flight], path: str) -> None:
    """Writes `path`: a standalone HTML page animating every flight (Meshcat
    served on localhost only while it is built)."""
    meshcat = Meshcat(MeshcatParams(host="localhost"))
    meshcat.StartRecording(
        frames_per_second=FRAMES_PER_SECOND, set_visualizations_while_recording=False
    )
    for i, flight in enumerate(flights):
        _record(meshcat, scenario, flight, with_obstacles=i == 0)
    meshcat.StopRecording()
    meshcat.PublishRecording()
    write_text(path, meshcat.StaticHtml())
