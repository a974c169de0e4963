"""A Meshcat animation of flown flights, saved as one standalone HTML file.

The flights are replayed from their logs rather than recorded while they are
simulated: a visualiser in the simulated diagram would add publish events
that change the integrator's steps, and so the flight. Each flight gets a
small diagram (SceneGraph, the shapes of each of its vehicles in its
method's colour, Drake's MeshcatVisualizer under the prefix of its method);
setting the logged states, and the moving obstacles' poses, frame by frame
and publishing records the animation. The obstacles are drawn once, the
ground as a slab under the scene (Meshcat draws no half space), and each
vehicle's whole path as a line of its method's colour; each vehicle's goal
is a gold sphere of the goal tolerance's radius (the "reached" ball). The
page opens with the camera framing the whole scene; its title names the
scenario and a legend gives each method's colour and outcome. Meshcat
serves on localhost while the page is built, silently: nothing is served
once it is written.
"""

import html
import logging
import re

import numpy as np
from matplotlib.colors import to_hex, to_rgba
from pydrake.geometry import (
    Box,
    Meshcat,
    MeshcatParams,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    Rgba,
    SceneGraph,
    Sphere,
)
from pydrake.math import RigidTransform
from pydrake.systems.framework import DiagramBuilder

from mfi_drake.app.figures import OUTCOME_WORDS, map_drawn
from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.files import write_text
from mfi_drake.flight.methods import appearance
from mfi_drake.flight.result import Flight, outcome
from mfi_drake.systems.sensors import VehicleGeometry
from mfi_drake.world.motion import obstacle_position
from mfi_drake.world.obstacles import GROUND_RGBA, register_obstacles
from mfi_drake.world.shapes import bounding_radius

FRAMES_PER_SECOND = 32.0
FIELD_OF_VIEW_DEG = 75.0  # Meshcat's default perspective camera
VIEW_DIRECTION = np.array([-0.5, -0.7, 0.8])  # from the scene's centre
GROUND_THICKNESS = 0.05  # m, of the slab drawn for the ground
GOAL_COLOUR = "gold"  # as the figures' goal star
MAP_POINT_SIZE = 0.03  # m, a point-cloud map's points as drawn
MAP_RGBA = Rgba(0.35, 0.35, 0.4, 1.0)  # as the figures' map scatter


def offline_meshcat() -> Meshcat:
    """A Meshcat on localhost for building a page, without its "listening for
    connections" line: it is logged at INFO on the "drake" logger while it
    is constructed (pydrake routes Drake's log there)."""
    logger = logging.getLogger("drake")
    level = logger.level
    logger.setLevel(logging.WARNING)
    try:
        return Meshcat(MeshcatParams(host="localhost"))
    finally:
        logger.setLevel(level)


def _rgba(method: str) -> Rgba:
    return Rgba(*to_rgba(appearance(method)[1]))


def _record(
    meshcat: Meshcat, scenario: Scenario, flight: Flight, with_obstacles: bool
) -> None:
    vehicle = as_vehicle(scenario.vehicle)
    builder = DiagramBuilder()
    scene_graph = builder.AddSystem(SceneGraph())
    frames = register_obstacles(scene_graph, scenario) if with_obstacles else None
    vehicles = [flight, *flight.others]
    geometries = []
    for k in range(len(vehicles)):
        geometry = builder.AddSystem(
            VehicleGeometry(
                scene_graph,
                vehicle.arm_length,
                vehicle.rotor_radius,
                _rgba(flight.method),
                name=f"vehicle_{k}",
            )
        )
        builder.Connect(
            geometry.get_output_port(0),
            scene_graph.get_source_pose_port(geometry.source_id),
        )
        geometries.append(geometry)
    visualizer = MeshcatVisualizer.AddToBuilder(
        builder, scene_graph, meshcat, MeshcatVisualizerParams(prefix=flight.method)
    )
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    scene_context = scene_graph.GetMyMutableContextFromRoot(context)
    visualizer_context = visualizer.GetMyContextFromRoot(context)
    frame_times = np.arange(0.0, flight.times[-1], 1.0 / FRAMES_PER_SECOND)
    for t in frame_times:
        context.SetTime(t)
        for geometry, flown in zip(geometries, vehicles, strict=True):
            # The last logged sample at or before the frame time.
            i = np.searchsorted(flown.times, t, side="right") - 1
            geometry.get_input_port(0).FixValue(
                geometry.GetMyMutableContextFromRoot(context), flown.log["state"][i]
            )
        if frames is not None:
            frames.fix(scene_graph, scene_context, t)
        visualizer.ForcedPublish(visualizer_context)
    for k, flown in enumerate(vehicles):
        meshcat.SetLine(
            f"paths/{flight.method}/{k}",
            flown.positions.T.copy(),
            line_width=2.0,
            rgba=_rgba(flight.method),
        )


def scene_box(scenario: Scenario, flights: list[Flight]) -> tuple:
    """(low, high) corners of a box holding every vehicle's path, start and
    goal, and every obstacle wherever it went."""
    points = [np.asarray(scenario.start, float), np.asarray(scenario.goal, float)]
    points.append(map_drawn(scenario))
    for flight in flights:
        points += [f.positions for f in (flight, *flight.others)]
    for obstacle in scenario.obstacles:
        reach = bounding_radius(scenario, obstacle.shape)
        centres = np.atleast_2d(obstacle_position(obstacle, flights[0].times))
        points += [centres - reach, centres + reach]
    points = np.vstack([np.atleast_2d(p) for p in points])
    return points.min(axis=0), points.max(axis=0)


def frame_scene(meshcat: Meshcat, low: np.ndarray, high: np.ndarray) -> None:
    """Points the camera at the box's centre from VIEW_DIRECTION, far enough
    for the box's bounding sphere to fill the view."""
    centre = (low + high) / 2.0
    radius = max(float(np.linalg.norm(high - low)) / 2.0, 1.0)
    distance = 1.1 * radius / np.sin(np.radians(FIELD_OF_VIEW_DEG) / 2.0)
    direction = VIEW_DIRECTION / np.linalg.norm(VIEW_DIRECTION)
    meshcat.SetCameraPose(centre + distance * direction, centre)


def draw_ground(meshcat: Meshcat, height: float, low, high) -> None:
    """A slab whose top is the ground, a metre beyond the scene each way."""
    size = np.asarray(high[:2]) - np.asarray(low[:2]) + 2.0
    centre = (np.asarray(low[:2]) + np.asarray(high[:2])) / 2.0
    meshcat.SetObject("ground", Box(*size, GROUND_THICKNESS), GROUND_RGBA)
    meshcat.SetTransform(
        "ground", RigidTransform([*centre, height - GROUND_THICKNESS / 2.0])
    )


def draw_map(meshcat: Meshcat, scenario: Scenario) -> None:
    """A point-cloud map's points (`figures.map_drawn`), "map", grey."""
    drawn = map_drawn(scenario)
    if len(drawn):
        from pydrake.perception import PointCloud  # only a map pays its import

        cloud = PointCloud(len(drawn))
        cloud.mutable_xyzs()[:] = drawn.T
        meshcat.SetObject("map", cloud, MAP_POINT_SIZE, MAP_RGBA)


def draw_goals(meshcat: Meshcat, scenario: Scenario) -> None:
    """Each vehicle's goal as a gold ball of radius goal_tolerance: "goal" the
    scenario's own, "other_goals/<k>" those of its other vehicles."""
    goals = [scenario.goal] + [other.goal for other in scenario.other_vehicles]
    for k, goal in enumerate(goals):
        path = "goal" if k == 0 else f"other_goals/{k - 1}"
        rgba = Rgba(*to_rgba(GOAL_COLOUR, 0.8))
        meshcat.SetObject(path, Sphere(scenario.goal_tolerance), rgba)
        meshcat.SetTransform(path, RigidTransform(np.asarray(goal, float)))


def legend_html(flights: list[Flight]) -> str:
    """A box in the page's lower left: each method's colour, label and
    outcome, and the goal's marker."""
    rows = []
    for flight in flights:
        label, colour = appearance(flight.method)
        words = OUTCOME_WORDS[outcome(flight.metrics)]
        rows.append((to_hex(colour), f"{label} ({words})"))
    rows.append((to_hex(GOAL_COLOUR), "goal"))
    items = "".join(
        f'<div><span style="display:inline-block;width:18px;height:6px;'
        f'margin-right:6px;vertical-align:middle;background:{colour}"></span>'
        f"{html.escape(text)}</div>"
        for colour, text in rows
    )
    return (
        '<div id="legend" style="position:fixed;left:10px;bottom:10px;'
        "z-index:10;padding:6px 10px;background:rgba(255,255,255,0.85);"
        'font:13px sans-serif;border-radius:4px">' + items + "</div>"
    )


def titled_page(page: str, title: str, legend: str) -> str:
    """Meshcat's static page with `title` as its <title> and `legend` at the
    top of its <body>."""
    # Replaced by functions: a scenario's name may hold a backslash.
    new_title = f"<title>{html.escape(title)}</title>"
    page, titled = re.subn(r"<title>.*?</title>", lambda _: new_title, page, count=1)
    page, bodied = re.subn(r"<body[^>]*>", lambda m: m[0] + legend, page, count=1)
    if not (titled and bodied):  # a Meshcat page of another shape
        raise RuntimeError("Meshcat's static page has no <title> or <body>")
    return page


def write_animation(scenario: Scenario, flights: list[Flight], path: str) -> None:
    """Writes `path`: a standalone HTML page animating every flight (Meshcat
    served on localhost only while it is built)."""
    meshcat = offline_meshcat()
    meshcat.StartRecording(
        frames_per_second=FRAMES_PER_SECOND, set_visualizations_while_recording=False
    )
    for i, flight in enumerate(flights):
        _record(meshcat, scenario, flight, with_obstacles=i == 0)
    meshcat.StopRecording()
    meshcat.PublishRecording()
    low, high = scene_box(scenario, flights)
    if scenario.ground is not None:
        low[2] = min(low[2], scenario.ground.height)
        draw_ground(meshcat, scenario.ground.height, low, high)
    draw_goals(meshcat, scenario)
    draw_map(meshcat, scenario)
    frame_scene(meshcat, low, high)
    labels = ", ".join(appearance(f.method)[0] for f in flights)
    title = f"{scenario.name}: {labels} (mfi-drake)"
    write_text(path, titled_page(meshcat.StaticHtml(), title, legend_html(flights)))
