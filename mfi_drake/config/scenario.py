"""Scenarios: the typed dataclasses of a scenario file and their checks.

A scenario says where the vehicle starts and must go, which vehicle flies,
how it senses, which obstacles exist (unknown to the navigator), and any
overrides of the navigator parameters and of Drake's SimulatorConfig.

`config.scenario_yaml` reads and writes them (`parse_scenario`).
`check_scenario` finds every problem that needs no geometry;
`world.validation.load_scenario` adds the geometric ones. Both raise
`ScenarioError` naming the file, the field and the value.
"""

import dataclasses
import math
import os
from dataclasses import dataclass, field

import numpy as np
from pydrake.systems.analysis import SimulatorConfig

from mfi_drake.config.checks import (
    ScenarioError,
    check_positive,
    check_vector,
    fail,
    is_number,
)
from mfi_drake.config.dynamic import (
    MOTION_KEYS,
    Ground,
    Motion,
    OtherVehicle,
    RelativeVelocity,
)
from mfi_drake.config.faults import Faults, fault_problems
from mfi_drake.config.parameters import (
    ApfParams,
    GfParams,
    NavigatorParams,
    baseline_problems,
    field_problems,
    paper_form,
    validate_params,
)
from mfi_drake.config.sensors import Sensor, SphereSensor, check_sensor
from mfi_drake.config.vehicle_model import VehicleModel, vehicle_field_problems
from mfi_drake.config.vehicles import Vehicle
from mfi_drake.config.worlds import WorldPose, world_problems
from mfi_drake.maths.escape import EscapeParams
from mfi_drake.maths.point_maps import MAP_VOXEL

FLEET_INTEGRATIONS = ("separate", "one")
# How the chain is evaluated (docs/performance.md, "Engines"): "systems",
# the design card's diagram of LeafSystems; "compiled", the same maths in
# one compiled system.
ENGINES = ("systems", "compiled")
# A `world:` that is a point-cloud map (any case: scanners write ".LAS").
MAP_SUFFIXES = (".ply", ".pcd", ".las", ".laz", ".xyz", ".pts")


@dataclass
class Box:
    size: list[float] = field(default_factory=lambda: [1.0, 1.0, 1.0])  # m


@dataclass
class Sphere:
    radius: float = 0.5  # m


@dataclass
class Cylinder:
    radius: float = 0.5  # m
    length: float = 1.0  # m, along the obstacle's z axis


@dataclass
class Capsule:
    radius: float = 0.5  # m
    length: float = 1.0  # m, of the cylindrical part, along z


@dataclass
class Ellipsoid:
    radii: list[float] = field(default_factory=lambda: [0.5, 0.5, 0.5])  # m


@dataclass
class Convex:
    """The convex hull of a mesh file's vertices or of `vertices` given
    inline (one of the two): a scenario with inline vertices carries its
    whole geometry, so it flies anywhere (a sweep's fields and failure
    replays are written so)."""

    file: str = ""  # Wavefront OBJ; a relative path is relative to the YAML file
    scale: float = 1.0
    vertices: list[list[float]] = field(default_factory=list)  # m, in its frame


@dataclass
class Mesh:
    """A closed mesh of any shape, flown as the convex pieces it decomposes
    into (`world.decomposition`; loading replaces it by them)."""

    file: str = ""  # Wavefront OBJ; a relative path is relative to the YAML file
    scale: float = 1.0


Shape = Box | Sphere | Cylinder | Capsule | Ellipsoid | Convex | Mesh


@dataclass
class Obstacle:
    shape: Shape = field(default_factory=Box)
    position: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # m
    rpy_deg: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # deg
    motion: Motion | None = None  # none: static (docs/dynamic.md)
    # What errors call it ("" : "an obstacle"); a world file's obstacles are
    # named "world 'yard.sdf' model 'wall' geometry 'collision'".
    name: str = ""


def default_simulator_config() -> SimulatorConfig:
    """Error-controlled RK3 at accuracy 1e-4 (the logger records every step
    through its own per-step event, so no forced publishing is needed)."""
    return SimulatorConfig(
        integration_scheme="runge_kutta3",
        max_step_size=0.1,
        accuracy=1e-4,
        use_error_control=True,
        target_realtime_rate=0.0,
    )


@dataclass
class Scenario:
    name: str = "unnamed"
    start: list[float] = field(default_factory=lambda: [0.0, 0.0, 1.5])  # m
    goal: list[float] = field(default_factory=list)  # m; required: no default
    duration: float = 30.0  # s of simulated time
    vehicle: str | Vehicle | VehicleModel = "drake_default"  # docs/vehicles.md
    sensor: Sensor = field(default_factory=SphereSensor)
    obstacles: list[Obstacle] = field(default_factory=list)
    # A Gazebo (.world, .sdf), URDF or MJCF (.xml) file, relative to the YAML
    # file, whose models' collision geometries are obstacles too: loading
    # appends them to `obstacles` and empties this (docs/usage.md, "Worlds").
    # Or a point-cloud map (MAP_SUFFIXES), its points thinned into map_points.
    world: str = ""
    # Where the world file is placed in the scenario's frame, and the folders
    # (relative to the YAML file) searched first for its `model://` includes.
    world_pose: WorldPose = field(default_factory=WorldPose)
    model_paths: list[str] = field(default_factory=list)
    # [m] the voxel edge a point-cloud map is thinned to (maths.point_maps).
    map_voxel: float = MAP_VOXEL
    # A point-cloud map's thinned points [m], world frame: what a map file
    # loads into, and what travels to a sweep's workers.
    map_points: list[list[float]] = field(default_factory=list)
    ground: Ground | None = None  # none: no ground
    # Further vehicles flown at once (docs/dynamic.md).
    other_vehicles: list[OtherVehicle] = field(default_factory=list)
    # Hz: how often the vehicles of a fleet exchange their positions and
    # velocities (docs/fleets.md).
    exchange_hz: float = 10.0
    # How a fleet is integrated (docs/fleets.md): "separate", a diagram and
    # Simulator a vehicle exchanging states at exchange_hz; "one", every
    # vehicle in one diagram and integrator, MFI compiled.
    fleet_integration: str = "separate"
    # "systems" (a LeafSystem a block) or "compiled" (the chain in one
    # compiled system, `flight.fleet.OneIntegratorFleet`): see ENGINES.
    engine: str = "systems"
    relative_velocity: RelativeVelocity = field(default_factory=RelativeVelocity)
    navigator: NavigatorParams = field(default_factory=NavigatorParams)
    # The paper's literal MFI (method "mfi-paper"): its own gains, repairs off.
    mfi_paper: NavigatorParams = field(
        default_factory=lambda: paper_form(NavigatorParams())
    )
    apf: ApfParams = field(default_factory=ApfParams)  # the APF baseline's gains
    gf: GfParams = field(default_factory=GfParams)  # the GF baseline's gains
    # The escape rule of MFI (docs/nonconvex.md), with MFI's gains.
    escape: EscapeParams = field(default_factory=EscapeParams)
    # Keyword arguments of a user's field function (MODULE:NAME methods).
    field_gains: dict[str, float] = field(default_factory=dict)
    faults: Faults = field(default_factory=Faults)  # all off by default
    simulator: SimulatorConfig = field(default_factory=default_simulator_config)
    goal_tolerance: float = 0.1  # m, "reached" radius
    # Directory that relative mesh paths are resolved against (not in YAML).
    base_dir: str = ""


def _check_goal(where: str, name: str, goal: list[float]) -> None:
    """A goal has no default: an empty one was not given."""
    if goal == []:
        raise ScenarioError(
            f"{where}: {name}: missing; every vehicle needs the point [x, y, z] "
            "(m) it flies to"
        )
    check_vector(where, name, goal)


def mesh_path(scenario: Scenario, shape: Convex) -> str:
    """Absolute path of a convex mesh file."""
    return os.path.join(scenario.base_dir, shape.file)


def _check_convex(where: str, shape: Convex) -> None:
    """A file or inline vertices, not both; each vertex 3 finite numbers. The
    hull's volume is checked with the file's (`world.validation`)."""
    if bool(shape.file) == bool(shape.vertices):
        fail(where, "shape", shape, "must give one of file and vertices")
    for i, vertex in enumerate(shape.vertices):
        check_vector(where, f"shape.vertices[{i}]", vertex)


def _check_shape(where: str, shape) -> None:
    """Every size of every shape kind is > 0: 3-vectors (Box.size,
    Ellipsoid.radii) component-wise, numbers (radius, length, scale) as a
    whole. A convex shape's file is checked where meshes are read
    (`world.validation`)."""
    if not isinstance(shape, Shape):
        fail(where, "shape", shape, "unknown shape")
    if isinstance(shape, Convex):
        _check_convex(where, shape)
    if isinstance(shape, Mesh) and not shape.file:
        fail(where, "shape.file", shape.file, "must name an OBJ file")
    for f in dataclasses.fields(shape):
        value = getattr(shape, f.name)
        if f.name == "vertices":
            continue
        if isinstance(value, list):
            check_vector(where, f"shape.{f.name}", value, positive=True)
        elif not isinstance(value, str):
            check_positive(where, f"shape.{f.name}", value)


def _check_motion(where: str, motion: Motion) -> None:
    for key in MOTION_KEYS:
        check_vector(where, f"motion.{key}", getattr(motion, key))
    if any(w < 0.0 for w in motion.angular_frequency):
        fail(where, "motion.angular_frequency", motion.angular_frequency, "must be ≥ 0")


def _check_dynamic(where: str, scenario: Scenario) -> None:
    """The other vehicles and how a fleet flies (docs/dynamic.md);
    `world.validation` checks where the vehicles are."""
    for i, other in enumerate(scenario.other_vehicles):
        check_vector(where, f"other_vehicles[{i}].start", other.start)
        _check_goal(where, f"other_vehicles[{i}].goal", other.goal)
    if scenario.other_vehicles and scenario.faults != Faults():
        fail(
            where, "other_vehicles", scenario.other_vehicles, "are flown without faults"
        )
    check_positive(where, "exchange_hz", scenario.exchange_hz)
    if scenario.fleet_integration not in FLEET_INTEGRATIONS:
        fail(
            where,
            "fleet_integration",
            scenario.fleet_integration,
            f"must be one of {', '.join(FLEET_INTEGRATIONS)}",
        )
    if scenario.engine not in ENGINES:
        fail(where, "engine", scenario.engine, f"must be one of {', '.join(ENGINES)}")
    if (
        scenario.engine == "compiled"
        and scenario.other_vehicles
        and scenario.fleet_integration != "one"
    ):
        fail(
            where,
            "engine",
            scenario.engine,
            "a fleet flies compiled on one integrator (fleet_integration: one)",
        )


def check_scenario(scenario: Scenario, where: str) -> None:
    """Raises ScenarioError for the first problem found that needs no
    geometry, naming `where`."""
    if not scenario.name:
        fail(where, "name", scenario.name, "must not be empty")
    check_vector(where, "start", scenario.start)
    _check_goal(where, "goal", scenario.goal)
    check_positive(where, "duration", scenario.duration)
    check_positive(where, "goal_tolerance", scenario.goal_tolerance)
    check_navigation_fields(scenario, where)
    _check_world(where, scenario)


def check_navigation_fields(scenario: object, where: str) -> None:
    """The fields a Scenario shares with a `config.navigation.NavigationConfig`
    (`scenario`: either): vehicle, sensor, every method's gains, faults,
    ground, relative velocity."""
    for name, value, reason in vehicle_field_problems(scenario.vehicle):
        fail(where, name, value, reason)
    check_sensor(where, scenario.sensor)
    for key in ("navigator", "mfi_paper"):
        for name, value, reason in validate_params(getattr(scenario, key)):
            fail(where, f"{key}.{name}", value, reason)
    for key in ("apf", "gf"):
        params = getattr(scenario, key)
        for name, value, reason in field_problems(params) or baseline_problems(params):
            fail(where, f"{key}.{name}", value, reason)
    for name, value, reason in field_problems(scenario.escape):
        fail(where, f"escape.{name}", value, reason)
    for name, value in scenario.field_gains.items():
        if not is_number(value) or not math.isfinite(value):
            fail(where, f"field_gains.{name}", value, "must be a finite number")
    for name, value, reason in fault_problems(scenario.faults):
        fail(where, f"faults.{name}", value, reason)
    if scenario.ground is not None:
        height = scenario.ground.height
        if not is_number(height) or not math.isfinite(height):
            fail(where, "ground.height", height, "must be a finite number")
    estimate = scenario.relative_velocity
    check_positive(where, "relative_velocity.rate_hz", estimate.rate_hz)
    check_positive(where, "relative_velocity.gate", estimate.gate)
    tau = estimate.time_constant
    if not is_number(tau) or not math.isfinite(tau) or tau < 0.0:
        fail(where, "relative_velocity.time_constant", tau, "must be a number ≥ 0")
    turn = estimate.keep_right
    if not is_number(turn) or not 0.0 <= turn < 90.0:
        fail(where, "relative_velocity.keep_right", turn, "must be in [0, 90) degrees")


def _check_world(where: str, scenario: Scenario) -> None:
    sim = scenario.simulator
    check_positive(where, "simulator.accuracy", sim.accuracy)
    check_positive(where, "simulator.max_step_size", sim.max_step_size)
    for i, obstacle in enumerate(scenario.obstacles):
        at = f"{where}: obstacles[{i}]"
        _check_shape(at, obstacle.shape)
        check_vector(at, "position", obstacle.position)
        check_vector(at, "rpy_deg", obstacle.rpy_deg)
        if obstacle.motion is not None:
            _check_motion(at, obstacle.motion)
        if not obstacle.name.isprintable():  # errors quote it in their one line
            fail(at, "name", obstacle.name, "must be one line of printable text")
    _check_dynamic(where, scenario)
    check_vector(where, "world_pose.position", scenario.world_pose.position)
    check_vector(where, "world_pose.rpy_deg", scenario.world_pose.rpy_deg)
    model_paths, pose = scenario.model_paths, scenario.world_pose
    for name, value, reason in world_problems(scenario.world, pose, model_paths):
        fail(where, name, value, reason)
    _check_map(where, scenario)


def _check_map(where: str, scenario: Scenario) -> None:
    """A point-cloud map is the whole world, read by the sphere sensor
    alone (`systems.point_map`): no cameras (a cloud has no surfaces to
    render), no obstacles, ground or other vehicles beside it."""
    check_positive(where, "map_voxel", scenario.map_voxel)
    try:  # at once (a map holds many points); point by point to name one
        points = np.asarray(scenario.map_points, dtype=float).reshape(-1, 3)
        whole = len(points) == len(scenario.map_points)
    except (ValueError, TypeError):
        whole = False
    if not (whole and np.isfinite(points).all()):
        for i, point in enumerate(scenario.map_points):
            check_vector(where, f"map_points[{i}]", point)
    if not (scenario.map_points or scenario.world.lower().endswith(MAP_SUFFIXES)):
        return
    value = scenario.world or f"{len(scenario.map_points)} map_points"
    beside = {
        "cameras (a point cloud has no surfaces to render; fly it with the "
        "sphere sensor)": not isinstance(scenario.sensor, SphereSensor),
        "obstacles": bool(scenario.obstacles),
        "ground": scenario.ground is not None,
        "other vehicles": bool(scenario.other_vehicles),
        "map_points as well": bool(scenario.world and scenario.map_points),
    }
    for what, given in beside.items():
        if given:
            fail(where, "world", value, f"a point-cloud map flies with no {what}")
