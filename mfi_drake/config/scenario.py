"""Scenario files: typed dataclasses loaded with Drake's `yaml_load_typed`.

A scenario says where the vehicle starts and must go, which vehicle flies,
how it senses, which obstacles exist (unknown to the navigator), and any
overrides of the navigator parameters and of Drake's SimulatorConfig.

Scenarios layer as in Drake's hardware_sim: `parse_scenario` loads a file
onto the defaults, then each override (YAML text or an override file) onto
the result with `yaml_load_typed(..., defaults=...)`. `check_scenario` finds
every problem that needs no geometry; `world.validation.load_scenario` adds
the geometric ones. Both raise `ScenarioError` naming the file, the field
and the value.
"""

import dataclasses
import math
import os
import types
import typing
from dataclasses import dataclass, field

import yaml
from pydrake.common.schema import Transform
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed
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
from mfi_drake.config.vehicles import VEHICLES

FLEET_INTEGRATIONS = ("separate", "one")


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
    vehicle: str = "drake_default"
    sensor: Sensor = field(default_factory=SphereSensor)
    obstacles: list[Obstacle] = field(default_factory=list)
    # An SDFormat (.sdf) or URDF (.urdf) file, relative to the YAML file, whose
    # static models' collision geometries are obstacles too: loading appends
    # them to `obstacles` and empties this (docs/usage.md, "Worlds").
    world: str = ""
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
    relative_velocity: RelativeVelocity = field(default_factory=RelativeVelocity)
    navigator: NavigatorParams = field(default_factory=NavigatorParams)
    # The paper's literal MFI (method "mfi-paper"): its own gains, repairs off.
    mfi_paper: NavigatorParams = field(
        default_factory=lambda: paper_form(NavigatorParams())
    )
    apf: ApfParams = field(default_factory=ApfParams)  # the APF baseline's gains
    gf: GfParams = field(default_factory=GfParams)  # the GF baseline's gains
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
    """The ground, the other vehicles and the relative-velocity estimate
    (docs/dynamic.md); `world.validation` checks where the vehicles are."""
    if scenario.ground is not None:
        height = scenario.ground.height
        if not _is_number(height) or not math.isfinite(height):
            fail(where, "ground.height", height, "must be a finite number")
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
    estimate = scenario.relative_velocity
    _check_positive(where, "relative_velocity.rate_hz", estimate.rate_hz)
    _check_positive(where, "relative_velocity.gate", estimate.gate)
    tau = estimate.time_constant
    if not _is_number(tau) or not math.isfinite(tau) or tau < 0.0:
        fail(where, "relative_velocity.time_constant", tau, "must be a number ≥ 0")
    turn = estimate.keep_right
    if not _is_number(turn) or not 0.0 <= turn < 90.0:
        fail(where, "relative_velocity.keep_right", turn, "must be in [0, 90) degrees")


def check_scenario(scenario: Scenario, where: str) -> None:
    """Raises ScenarioError for the first problem found that needs no
    geometry, naming `where`."""
    if not scenario.name:
        fail(where, "name", scenario.name, "must not be empty")
    _check_vector(where, "start", scenario.start)
    _check_goal(where, "goal", scenario.goal)
    _check_positive(where, "duration", scenario.duration)
    _check_positive(where, "goal_tolerance", scenario.goal_tolerance)
    if scenario.vehicle not in VEHICLES:
        fail(where, "vehicle", scenario.vehicle, f"must be one of {sorted(VEHICLES)}")
    if isinstance(scenario.sensor, SphereSensor):
        _check_positive(where, "sensor.radius", scenario.sensor.radius)
    elif isinstance(scenario.sensor, Cameras):
        _check_cameras(where, scenario.sensor)
    else:
        fail(where, "sensor", scenario.sensor, "unknown sensor")
    for key in ("navigator", "mfi_paper"):
        for name, value, reason in validate_params(getattr(scenario, key)):
            fail(where, f"{key}.{name}", value, reason)
    for key in ("apf", "gf"):
        params = getattr(scenario, key)
        for name, value, reason in field_problems(params) or baseline_problems(params):
            fail(where, f"{key}.{name}", value, reason)
    for name, value in scenario.field_gains.items():
        if not _is_number(value) or not math.isfinite(value):
            fail(where, f"field_gains.{name}", value, "must be a finite number")
    for name, value, reason in fault_problems(scenario.faults):
        fail(where, f"faults.{name}", value, reason)
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


class _TaggedLoader(yaml.SafeLoader):
    """Reads `!Tag {..}` as {"_tag": "Tag", ...} for the schema check."""


def _construct_tagged(loader, suffix, node):
    if isinstance(node, yaml.MappingNode):
        data = loader.construct_mapping(node, deep=True)
    else:
        data = {"_value": loader.construct_object(node, deep=True)}
    return {"_tag": suffix, **data}


_TaggedLoader.add_multi_constructor("!", _construct_tagged)


def _is_number(x) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _check_schema(data, schema, where: str, name: str) -> None:
    """Checks raw YAML `data` against dataclass `schema` so that a wrong key or
    type is reported with its field path (yaml_load_typed's own messages do
    not always name the field). Drake's own config classes are left to
    yaml_load_typed."""
    shown = name or "scenario"
    if not dataclasses.is_dataclass(schema):
        _check_drake_keys(data, schema, where, name)
        return
    if not isinstance(data, dict):
        fail(where, shown, data, f"must be a mapping of {schema.__name__} fields")
    hints = typing.get_type_hints(schema)
    for key, value in data.items():
        if key == "_tag":
            continue
        field_name = f"{name}.{key}" if name else str(key)
        if key not in hints or key == "base_dir":
            fail(where, field_name, value, f"unknown field of {schema.__name__}")
        _check_value(value, hints[key], where, field_name)


def _check_drake_keys(data, schema, where: str, name: str) -> None:
    """A key that a Drake config class (e.g. a Transform) does not have is
    reported with its field path; its values are left to yaml_load_typed."""
    known = {f.name for f in getattr(schema, "__fields__", ())}
    if known and isinstance(data, dict):
        for key, value in data.items():
            if key != "_tag" and key not in known:
                reason = f"unknown field of {schema.__name__}"
                fail(where, f"{name}.{key}", value, reason)


def _check_value(value, hint, where: str, name: str) -> None:
    origin = typing.get_origin(hint)
    if hint is float:
        if not _is_number(value):
            fail(where, name, value, "must be a number")
    elif hint is int:
        if not isinstance(value, int) or isinstance(value, bool):
            fail(where, name, value, "must be an integer")
    elif hint is bool:
        if not isinstance(value, bool):
            fail(where, name, value, "must be true or false")
    elif hint is str:
        if not isinstance(value, str):
            fail(where, name, value, "must be a string")
    elif origin is list:
        if not isinstance(value, list):
            fail(where, name, value, "must be a list")
        (item,) = typing.get_args(hint)
        for i, x in enumerate(value):
            _check_value(x, item, where, f"{name}[{i}]")
    elif origin in (types.UnionType, typing.Union):
        alternatives = typing.get_args(hint)
        if value is None and type(None) in alternatives:  # an optional block
            return
        options = {t.__name__: t for t in alternatives if t is not type(None)}
        # Untagged is the first alternative, as Drake writes and reads it.
        first = next(iter(options))
        tag = value.get("_tag", first) if isinstance(value, dict) else None
        if not isinstance(tag, str) or tag not in options:
            fail(
                where,
                name,
                tag or value,
                f"must be tagged one of !{', !'.join(options)}",
            )
        _check_schema(value, options[tag], where, name)
    else:
        _check_schema(value, hint, where, name)


def _read_yaml(text: str, where: str):
    try:
        return yaml.load(text, Loader=_TaggedLoader)
    except (yaml.YAMLError, RecursionError) as e:
        message = " ".join(str(e).split())
        raise ScenarioError(f"{where}: not valid YAML: {message}") from None


def _read_file(path: str) -> str:
    if os.path.isdir(path):
        raise ScenarioError(f"{path}: is a directory, not a YAML file")
    if not os.path.isfile(path):
        raise ScenarioError(f"{path}: no such file")
    try:
        with open(path) as f:
            return f.read()
    except (UnicodeDecodeError, OSError) as e:
        message = " ".join(str(e).split())
        raise ScenarioError(f"{path}: not valid YAML: {message}") from None


def layer(scenario: Scenario, text: str, where: str) -> Scenario:
    """`scenario` with the YAML mapping `text` loaded on top of it (fields
    that `text` does not name keep their values). Not validated."""
    raw = _read_yaml(text, where)
    if raw is None:
        return scenario
    _check_schema(raw, Scenario, where, "")
    base_dir = scenario.base_dir
    layered = _typed(Scenario, text, where, defaults=scenario)
    layered.base_dir = base_dir
    return layered


def _typed(schema, text: str, where: str, **defaults):
    """yaml_load_typed(schema, text), any error it raises as ScenarioError."""
    try:
        return yaml_load_typed(schema=schema, data=text, **defaults)
    except Exception as e:  # yaml_load_typed raises several types
        message = " ".join(str(e).split())
        raise ScenarioError(f"{where}: {message}") from None


def read_faults(text: str, where: str) -> Faults:
    """A `faults:` block given as YAML text (sweep --faults), checked like a
    scenario's: a bad key or value raises ScenarioError naming it."""
    raw = _read_yaml(text, where)
    if raw is None:  # '', '~', 'null': no faults
        return Faults()
    _check_schema(raw, Faults, where, "faults")
    faults = _typed(Faults, text, where)
    for name, value, reason in fault_problems(faults):
        fail(where, f"faults.{name}", value, reason)
    return faults


def read_override(path: str) -> tuple[str, str]:
    """(path, its text): an override file for `parse_scenario`."""
    return path, _read_file(path)


def layered_name(name: str, overrides: list[tuple[str, str]] = ()) -> str:
    """What an error names for scenario `name` with `overrides` layered on
    it: a bad value may come from any layer ("a.yaml with --set 'x: 1'")."""
    if not overrides:
        return name
    return f"{name} with {', '.join(where for where, _ in overrides)}"


def parse_scenario(path: str, overrides: list[tuple[str, str]] = ()) -> Scenario:
    """The scenario file `path` on the defaults, then each override (where,
    YAML text) on top, e.g. ("--set", "faults: {sensor_noise_std: 0.05}") or
    `read_override("tuned.yaml")`. Checked by `check_scenario`; relative mesh
    paths resolve against `path`'s directory."""
    scenario = Scenario(base_dir=os.path.dirname(os.path.abspath(path)))
    scenario = layer(scenario, _read_file(path), path)
    for where, text in overrides:
        scenario = layer(scenario, text, where)
    check_scenario(scenario, layered_name(path, overrides))
    return scenario


def scenario_to_yaml(scenario: Scenario) -> str:
    """The whole scenario, base_dir and every default included (a worker's
    defaults need not be the client's), as YAML text: what travels to a
    sweep worker (Drake's SimulatorConfig does not pickle)."""
    return yaml_dump_typed(scenario)


def scenario_from_yaml(text: str) -> Scenario:
    """The inverse of `scenario_to_yaml` (trusted text: not validated)."""
    return yaml_load_typed(schema=Scenario, data=text, defaults=Scenario())
