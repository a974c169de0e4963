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
from pydrake.common.schema import Transform
from pydrake.systems.analysis import SimulatorConfig

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
from mfi_drake.config.vehicle_model import VehicleModel, vehicle_field_problems
from mfi_drake.config.vehicles import Vehicle
from mfi_drake.config.worlds import WorldPose, world_problems
from mfi_drake.maths.escape import EscapeParams
from mfi_drake.maths.layout import OBSTACLE_COUNT
from mfi_drake.maths.point_maps import MAP_VOXEL

FLEET_INTEGRATIONS = ("separate", "one")
# How the chain is evaluated (docs/performance.md, "Engines"): "systems",
# the design card's diagram of LeafSystems; "compiled", the same maths in
# one compiled system.
ENGINES = ("systems", "compiled")
# A `world:` that is a point-cloud map (any case: scanners write ".LAS").
MAP_SUFFIXES = (".ply", ".pcd", ".las", ".laz")


class ScenarioError(ValueError):
    """A scenario that cannot be flown; the message is one line for the user."""


# --- obstacle shapes (the YAML tags !Box, !Sphere, ...) -----------------------
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


# --- sensors ------------------------------------------------------------------
@dataclass
class SphereSensor:
    """Sees every obstacle point within `radius` of the vehicle centre."""

    radius: float = 3.0  # m, the paper's r_s
    readings: int = OBSTACLE_COUNT  # obstacles reported, nearest first (≥ 1)


@dataclass
class CameraImage:
    """The depth image of an on-board camera (square pixels, principal point
    at the centre)."""

    width: int = 160  # pixels
    height: int = 120  # pixels
    fov_y_deg: float = 60.0  # vertical field of view, degrees
    max_range: float = 6.0  # m; farther pixels are "no return"


MEMORY_S = 6.0  # s, default T: max_range / v_d (docs/depth_camera.md, "Memory")


@dataclass
class Gimbal:
    """A pan–tilt gimbal, stabilised in the world, that turns the camera
    toward the estimated velocity (docs/depth_camera.md, "Gimbal")."""

    rate_deg_s: float = 180.0  # largest slew rate of each axis
    min_speed: float = 0.2  # m/s; slower, the gimbal holds its direction


@dataclass
class DepthCamera(CameraImage):
    """An on-board depth camera (paper §VI-B) looking +x: a rig of one
    camera, fixed to the body or on a gimbal."""

    rate_hz: float = 30.0  # frames per second
    # The camera's pose: optical centre in the body frame [m] and orientation
    # [deg] in the body frame, or on a gimbal in the gimbal's frame (zero:
    # looking along its +x, image up = its +z).
    position: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy_deg: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    memory_s: float = MEMORY_S  # s, T: how long a seen point is remembered
    # None: fixed to the body, as in the paper; a `Gimbal`: looking where the
    # vehicle goes (docs/depth_camera.md, "Gimbal").
    gimbal: Gimbal | None = None
    readings: int = OBSTACLE_COUNT  # obstacles reported, nearest first (≥ 1)


def looking_forward() -> Transform:
    """X_BC of a camera at the body origin looking along body +x, image up =
    body +z (C: Drake's camera frame, +z along the view, +x image right)."""
    X_BC = Transform()
    X_BC.set_rotation_rpy_deg([-90.0, 0.0, -90.0])
    return X_BC


@dataclass
class RigCamera(CameraImage):
    """A camera of a `DepthCameraRig`, posed as Drake poses a camera:
    X_BC: {translation: [x, y, z], rotation: !Rpy {deg: [r, p, y]}}, the
    camera frame C (+z along the view, +x image right, +y image down) in the
    body frame B. Default: `looking_forward`."""

    X_BC: Transform = field(default_factory=looking_forward)


@dataclass
class DepthCameraRig:
    """Depth cameras on the body, rendering together at rate_hz; what they
    see is fused into one memory and one reading."""

    cameras: list[RigCamera] = field(default_factory=lambda: [RigCamera()])
    rate_hz: float = 30.0  # frames per second, every camera
    memory_s: float = MEMORY_S  # s, T: how long a seen point is remembered
    readings: int = OBSTACLE_COUNT  # obstacles reported, nearest first (≥ 1)


Sensor = SphereSensor | DepthCamera | DepthCameraRig
Cameras = DepthCamera | DepthCameraRig  # the sensors that render depth images


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
    # Or a point-cloud map (.ply, .pcd), its points thinned into map_points.
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


def fail(where: str, name: str, value, reason: str):
    if not name.isprintable():  # a YAML key may hold a line break
        name = repr(name)
    raise ScenarioError(f"{where}: {name} = {value!r}: {reason}")


def _check_vector(where, name, value, positive=False):
    if not isinstance(value, list) or len(value) != 3:
        fail(where, name, value, "must be a list of 3 numbers")
    for x in value:
        if not isinstance(x, int | float) or not math.isfinite(x):
            fail(where, name, value, "must hold finite numbers")
        if positive and x <= 0:
            fail(where, name, value, "must be > 0")


def _check_goal(where: str, name: str, goal: list[float]) -> None:
    """A goal has no default: an empty one was not given."""
    if goal == []:
        raise ScenarioError(
            f"{where}: {name}: missing; every vehicle needs the point [x, y, z] "
            "(m) it flies to"
        )
    _check_vector(where, name, goal)


def _check_positive(where, name, value):
    if not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
        fail(where, name, value, "must be a finite number > 0")


MIN_DEPTH = 0.02  # m; a depth camera's closer pixels come back as "too close"


def _check_image(where: str, name: str, camera: CameraImage) -> None:
    """`name`: the camera's path in the scenario, e.g. "sensor.cameras[1]"."""
    for size in ("width", "height"):
        value = getattr(camera, size)
        if not isinstance(value, int) or value <= 0:
            fail(where, f"{name}.{size}", value, "must be a whole number > 0")
    fov = camera.fov_y_deg
    _check_positive(where, f"{name}.fov_y_deg", fov)
    if fov >= 180.0:
        fail(where, f"{name}.fov_y_deg", fov, "must be < 180")
    _check_positive(where, f"{name}.max_range", camera.max_range)
    if camera.max_range <= MIN_DEPTH:
        fail(where, f"{name}.max_range", camera.max_range, f"must be > {MIN_DEPTH}")


def _check_camera_pose(where: str, name: str, X_BC: Transform) -> None:
    if X_BC.base_frame is not None:
        fail(where, f"{name}.base_frame", X_BC.base_frame, "must be left out (body)")
    if not X_BC.IsDeterministic():
        fail(where, name, X_BC, "must be one fixed pose")
    pose = X_BC.GetDeterministicValue()
    if not all(math.isfinite(x) for x in pose.GetAsMatrix4().ravel()):
        fail(where, name, X_BC, "must hold finite numbers")


def _check_cameras(where: str, sensor: Cameras) -> None:
    _check_positive(where, "sensor.rate_hz", sensor.rate_hz)
    _check_positive(where, "sensor.memory_s", sensor.memory_s)
    if isinstance(sensor, DepthCamera):
        _check_image(where, "sensor", sensor)
        _check_vector(where, "sensor.position", sensor.position)
        _check_vector(where, "sensor.rpy_deg", sensor.rpy_deg)
        if sensor.gimbal is not None:
            _check_positive(where, "sensor.gimbal.rate_deg_s", sensor.gimbal.rate_deg_s)
            _check_positive(where, "sensor.gimbal.min_speed", sensor.gimbal.min_speed)
        return
    if not sensor.cameras:
        fail(where, "sensor.cameras", sensor.cameras, "must hold a camera")
    for i, camera in enumerate(sensor.cameras):
        _check_image(where, f"sensor.cameras[{i}]", camera)
        _check_camera_pose(where, f"sensor.cameras[{i}].X_BC", camera.X_BC)


def mesh_path(scenario: Scenario, shape: Convex) -> str:
    """Absolute path of a convex mesh file."""
    return os.path.join(scenario.base_dir, shape.file)


def _check_convex(where: str, shape: Convex) -> None:
    """A file or inline vertices, not both; each vertex 3 finite numbers. The
    hull's volume is checked with the file's (`world.validation`)."""
    if bool(shape.file) == bool(shape.vertices):
        fail(where, "shape", shape, "must give one of file and vertices")
    for i, vertex in enumerate(shape.vertices):
        _check_vector(where, f"shape.vertices[{i}]", vertex)


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
            _check_vector(where, f"shape.{f.name}", value, positive=True)
        elif not isinstance(value, str):
            _check_positive(where, f"shape.{f.name}", value)


def _check_motion(where: str, motion: Motion) -> None:
    for key in MOTION_KEYS:
        _check_vector(where, f"motion.{key}", getattr(motion, key))
    if any(w < 0.0 for w in motion.angular_frequency):
        fail(where, "motion.angular_frequency", motion.angular_frequency, "must be ≥ 0")


def _check_dynamic(where: str, scenario: Scenario) -> None:
    """The other vehicles and how a fleet flies (docs/dynamic.md);
    `world.validation` checks where the vehicles are."""
    for i, other in enumerate(scenario.other_vehicles):
        _check_vector(where, f"other_vehicles[{i}].start", other.start)
        _check_goal(where, f"other_vehicles[{i}].goal", other.goal)
    if scenario.other_vehicles and scenario.faults != Faults():
        fail(
            where, "other_vehicles", scenario.other_vehicles, "are flown without faults"
        )
    _check_positive(where, "exchange_hz", scenario.exchange_hz)
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
    _check_vector(where, "start", scenario.start)
    _check_goal(where, "goal", scenario.goal)
    _check_positive(where, "duration", scenario.duration)
    _check_positive(where, "goal_tolerance", scenario.goal_tolerance)
    check_navigation_fields(scenario, where)
    _check_world(where, scenario)


def check_navigation_fields(scenario: object, where: str) -> None:
    """The fields a Scenario shares with a `config.navigation.NavigationConfig`
    (`scenario`: either): vehicle, sensor, every method's gains, faults,
    ground, relative velocity."""
    for name, value, reason in vehicle_field_problems(scenario.vehicle):
        fail(where, name, value, reason)
    if isinstance(scenario.sensor, SphereSensor):
        _check_positive(where, "sensor.radius", scenario.sensor.radius)
    elif isinstance(scenario.sensor, Cameras):
        _check_cameras(where, scenario.sensor)
    else:
        fail(where, "sensor", scenario.sensor, "unknown sensor")
    readings = scenario.sensor.readings
    if isinstance(readings, bool) or not isinstance(readings, int) or readings < 1:
        fail(where, "sensor.readings", readings, "must be an integer >= 1")
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
        if not _is_number(value) or not math.isfinite(value):
            fail(where, f"field_gains.{name}", value, "must be a finite number")
    for name, value, reason in fault_problems(scenario.faults):
        fail(where, f"faults.{name}", value, reason)
    if scenario.ground is not None:
        height = scenario.ground.height
        if not _is_number(height) or not math.isfinite(height):
            fail(where, "ground.height", height, "must be a finite number")
    estimate = scenario.relative_velocity
    _check_positive(where, "relative_velocity.rate_hz", estimate.rate_hz)
    _check_positive(where, "relative_velocity.gate", estimate.gate)
    tau = estimate.time_constant
    if not _is_number(tau) or not math.isfinite(tau) or tau < 0.0:
        fail(where, "relative_velocity.time_constant", tau, "must be a number ≥ 0")
    turn = estimate.keep_right
    if not _is_number(turn) or not 0.0 <= turn < 90.0:
        fail(where, "relative_velocity.keep_right", turn, "must be in [0, 90) degrees")


def _check_world(where: str, scenario: Scenario) -> None:
    sim = scenario.simulator
    _check_positive(where, "simulator.accuracy", sim.accuracy)
    _check_positive(where, "simulator.max_step_size", sim.max_step_size)
    for i, obstacle in enumerate(scenario.obstacles):
        at = f"{where}: obstacles[{i}]"
        _check_shape(at, obstacle.shape)
        _check_vector(at, "position", obstacle.position)
        _check_vector(at, "rpy_deg", obstacle.rpy_deg)
        if obstacle.motion is not None:
            _check_motion(at, obstacle.motion)
        if not obstacle.name.isprintable():  # errors quote it in their one line
            fail(at, "name", obstacle.name, "must be one line of printable text")
    _check_dynamic(where, scenario)
    _check_vector(where, "world_pose.position", scenario.world_pose.position)
    _check_vector(where, "world_pose.rpy_deg", scenario.world_pose.rpy_deg)
    model_paths, pose = scenario.model_paths, scenario.world_pose
    for name, value, reason in world_problems(scenario.world, pose, model_paths):
        fail(where, name, value, reason)
    _check_map(where, scenario)


def _check_map(where: str, scenario: Scenario) -> None:
    """A point-cloud map is the whole world, read by the sphere sensor
    alone (`systems.point_map`): no cameras (a cloud has no surfaces to
    render), no obstacles, ground or other vehicles beside it."""
    _check_positive(where, "map_voxel", scenario.map_voxel)
    try:  # at once (a map holds many points); point by point to name one
        points = np.asarray(scenario.map_points, dtype=float).reshape(-1, 3)
        whole = len(points) == len(scenario.map_points)
    except (ValueError, TypeError):
        whole = False
    if not (whole and np.isfinite(points).all()):
        for i, point in enumerate(scenario.map_points):
            _check_vector(where, f"map_points[{i}]", point)
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


def _is_number(x) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)
