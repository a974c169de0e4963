"""Seeded random obstacle fields for the Monte Carlo sweep.

The workspace (`Workspace`, all lengths in metres, world frame, z up):

- start = (0, 0, h) and goal = (L, 0, h): a straight start–goal line of
  length L = 10 along +x at height h = 2;
- obstacle centres are uniform in the box x ∈ [m, L − m], y ∈ [−w, w],
  z ∈ [h − w, h + w] with m = 1 and w = 2.5 (an 8 × 5 × 5 m³ box around the
  line); obstacles may overlap each other and stick out of the box;
- there is no floor or ceiling: the vehicle may pass any side of anything.

Density = obstacles per cubic metre of that box: a field holds
round(density × 200 m³) obstacles (0.1 → 20). Each obstacle is one of the
six shape kinds of the scenario format, drawn with equal probability, with a
uniformly random orientation and sizes in `shapes.SHAPES` (every obstacle fits in a
ball of radius ≲ 1.3 m). Convex obstacles are random prisms over a convex
polygon or stretched icosahedra, given by their vertices inline: a field is
one self-contained scenario, written nowhere until asked (`write_scenario`).

Each candidate obstacle that comes within the vehicle's collision radius plus
`Workspace.clearance` of the start or the goal (exact SceneGraph distance,
`obstacles.obstacle_distances`) is redrawn, so both are in free space with that
much room. Field `index` at seed `seed` uses the random stream
`default_rng([seed, index])`, one draw sequence per obstacle, so a field is
reproducible and a denser field with the same seed and index holds the
sparser one's obstacles plus more.

`near_goal` adds one obstacle of a random kind, size and orientation whose
surface lies a given gap from the goal, in a uniformly random direction from
it (docs/goals.md): the class of goals near surfaces. Its draws come from
default_rng([seed, index, GOAL_STREAM]), so the field's other obstacles are
those of the plain field.

`set_in_motion` makes a share of a field's obstacles move (docs/dynamic.md):
each chosen obstacle circles its drawn position at a constant speed, on a
circle of radius A in a random plane, from a random point of it; A is drawn
in `CIRCLE_RADII` and shrunk where needed so that the obstacle never comes
closer to the start or the goal than it was drawn (the distance is
1-Lipschitz). The choice is drawn from its own stream, default_rng([seed,
index, MOTION_STREAM]), so the field's obstacles are those of the static
field.
"""

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.common.yaml import yaml_dump_typed
from pydrake.math import RollPitchYaw, RotationMatrix

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import Motion
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.files import write_text
from mfi_drake.world.obstacles import obstacle_distances
from mfi_drake.world.shapes import SHAPES, convex_points, mesh_file
from mfi_drake.world.world_files import with_files

# The kinds in the order a field draws them from (the table's order).
SHAPE_KINDS = tuple(SHAPES.values())


@dataclass(frozen=True)
class Workspace:
    """Where the fields live; see the module docstring."""

    length: float = 10.0  # m, start → goal along +x
    height: float = 2.0  # m, z of the start–goal line
    half_width: float = 2.5  # m, obstacle centres within ±w of the line (y, z)
    margin: float = 1.0  # m, obstacle centres x ∈ [margin, length − margin]
    clearance: float = 0.5  # m, room around start and goal beyond the vehicle

    @property
    def start(self) -> list[float]:
        return [0.0, 0.0, self.height]

    @property
    def goal(self) -> list[float]:
        return [self.length, 0.0, self.height]

    @property
    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) corners of the box holding the obstacle centres."""
        w = self.half_width
        low = np.array([self.margin, -w, self.height - w])
        high = np.array([self.length - self.margin, w, self.height + w])
        return low, high

    @property
    def volume(self) -> float:
        low, high = self.box
        return float(np.prod(high - low))

    def obstacle_count(self, density: float) -> int:
        return round(density * self.volume)


DEFAULT_WORKSPACE = Workspace()
DEFAULT_DENSITY = 0.1  # obstacles per m³: 20 in the box
DEFAULT_DURATION = 60.0  # s of simulated time, ≥ 3× a 1 m/s flight of the line
CIRCLE_RADII = (1.0, 2.0)  # m, a moving obstacle's circle (set_in_motion)
MIN_CIRCLE = 0.25  # m, an obstacle with less room to move stays put
MOTION_STREAM = 1  # the random stream of set_in_motion
GOAL_STREAM = 3  # the random stream of near_goal


def field_name(seed: int, index: int, density: float) -> str:
    return f"field_d{density:g}_s{seed}_i{index}"


def random_rpy_deg(rng: np.random.Generator) -> list[float]:
    """Roll, pitch, yaw [deg] of a uniformly random rotation (a normalised
    4-D Gaussian is a uniform unit quaternion)."""
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    rpy = RollPitchYaw(RotationMatrix(Quaternion(q)))
    return [float(a) for a in np.degrees(rpy.vector())]


def random_obstacle(
    rng: np.random.Generator, low: np.ndarray, high: np.ndarray
) -> sc.Obstacle:
    """One obstacle of a random kind, size and orientation, its centre uniform
    in the box [low, high]."""
    kind = SHAPE_KINDS[rng.integers(len(SHAPE_KINDS))]
    return sc.Obstacle(
        shape=kind.random(rng, kind.sizes),
        position=[float(x) for x in rng.uniform(low, high)],
        # A sphere's orientation changes nothing; it draws none.
        rpy_deg=[0.0] * 3 if kind.name == "sphere" else random_rpy_deg(rng),
    )


def random_field(
    seed: int,
    index: int,
    density: float,
    workspace: Workspace = DEFAULT_WORKSPACE,
    vehicle: str = "drake_default",
    sensor: sc.Sensor | None = None,
    duration: float = DEFAULT_DURATION,
) -> sc.Scenario:
    """Field `index` of seed `seed` at `density` obstacles per m³ (see the
    module docstring)."""
    if not (math.isfinite(density) and density >= 0.0):
        raise ValueError(f"density = {density!r}: must be a finite number ≥ 0")
    name = field_name(seed, index, density)
    scenario = _field(name, workspace, vehicle, sensor, duration)
    needed = as_vehicle(vehicle).collision_radius + workspace.clearance
    low, high = workspace.box
    rng = np.random.default_rng([seed, index])
    for _ in range(workspace.obstacle_count(density)):
        while True:
            obstacle = random_obstacle(rng, low, high)
            alone = dataclasses.replace(scenario, obstacles=[obstacle])
            ends = [workspace.start, workspace.goal]
            if min(obstacle_distances(alone, ends)) >= needed:
                break
        scenario.obstacles.append(obstacle)
    return scenario


# A wall field's ranges (`wall_field`): m, m, m, deg.
WALL_LENGTHS = (6.0, 14.0)
WALL_THICKNESSES = (0.1, 0.4)
WALL_HEIGHTS = (2.0, 5.0)
WALL_YAW_DEG = 25.0
WALL_OVERLAP = 0.5  # m, the least the wall reaches past the line, each way
WALL_STREAM = 2  # the random stream of wall_field


def wall_name(seed: int, index: int) -> str:
    return f"wall_s{seed}_i{index}"


def wall_field(
    seed: int,
    index: int,
    workspace: Workspace = DEFAULT_WORKSPACE,
    vehicle: str = "drake_default",
    sensor: sc.Sensor | None = None,
    duration: float = DEFAULT_DURATION,
) -> sc.Scenario:
    """One long wall across the start–goal line: the structure random fields
    of small obstacles lack (a navigator must follow it for metres to get
    round or over it). A box of length, thickness and height uniform in
    `WALL_*`, yawed up to ±WALL_YAW_DEG from square to the line, which meets
    it in the middle fifth of the line's length and at least WALL_OVERLAP
    from every edge of the wall; stream default_rng([seed, index,
    WALL_STREAM]). The ends are clear of it by construction: each is at least
    0.4·length·cos(WALL_YAW_DEG) − thickness/2 ≈ 3.4 m from the wall's plane."""
    rng = np.random.default_rng([seed, index, WALL_STREAM])
    length, thickness, height = (
        rng.uniform(*r) for r in (WALL_LENGTHS, WALL_THICKNESSES, WALL_HEIGHTS)
    )
    yaw = rng.uniform(-WALL_YAW_DEG, WALL_YAW_DEG)
    reach = length / 2 - WALL_OVERLAP  # along the wall, from its centre
    lift = height / 2 - WALL_OVERLAP
    x = workspace.length * rng.uniform(0.4, 0.6)
    along = rng.uniform(-reach, reach)  # the line's crossing, from the centre
    # Shift the centre along the wall so the line crosses it at `along`.
    centre = [
        x + along * math.sin(math.radians(yaw)),
        -along * math.cos(math.radians(yaw)),
        workspace.height + rng.uniform(-lift, lift),
    ]
    return _field(
        wall_name(seed, index),
        workspace,
        vehicle,
        sensor,
        duration,
        obstacles=[
            sc.Obstacle(
                shape=sc.Box(size=[thickness, length, height]),
                position=[float(c) for c in centre],
                rpy_deg=[0.0, 0.0, float(yaw)],
            )
        ],
    )


def _field(
    name: str,
    workspace: Workspace,
    vehicle: str,
    sensor: sc.Sensor | None,
    duration: float,
    **fields,
) -> sc.Scenario:
    """A field's scenario from the workspace's start to its goal, with the
    sphere sensor unless `sensor` is given; `fields`: the rest."""
    return sc.Scenario(
        name=name,
        start=workspace.start,
        goal=workspace.goal,
        duration=duration,
        vehicle=vehicle,
        sensor=sensor if sensor is not None else sc.SphereSensor(),
        **fields,
    )


def near_goal(scenario: sc.Scenario, seed: int, index: int, gap: float) -> sc.Scenario:
    """`scenario` (field `index` of seed `seed`) with one more obstacle,
    drawn as `random_obstacle` draws one, moved along a uniformly random
    direction u from the goal until its surface is `gap` metres from the
    goal (to 0.1 mm, never less; see the module docstring). The signed
    distance to a convex body is convex along the ray and negative at its
    centre: it crosses `gap` once."""
    rng = np.random.default_rng([seed, index, GOAL_STREAM])
    goal = np.asarray(scenario.goal, float)
    obstacle = random_obstacle(rng, goal, goal)
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)

    def gap_at(t: float) -> float:
        moved = dataclasses.replace(obstacle, position=[float(x) for x in goal + t * u])
        return obstacle_distances(
            dataclasses.replace(scenario, obstacles=[moved]), [goal]
        )[0]

    low, high = 0.0, 1.0
    while gap_at(high) < gap:
        low, high = high, 2.0 * high
    while high - low > 1e-4:
        middle = 0.5 * (low + high)
        low, high = (middle, high) if gap_at(middle) < gap else (low, middle)
    placed = dataclasses.replace(obstacle, position=[float(x) for x in goal + high * u])
    return dataclasses.replace(
        scenario,
        name=f"{scenario.name}_g{gap:g}",
        obstacles=[*scenario.obstacles, placed],
    )


def circle_motion(rng: np.random.Generator, radius: float, speed: float) -> Motion:
    """A circle of `radius` about the drawn position in a uniformly random
    plane, at `speed` m/s from a random point: A (a sin(ωt + ψ) + b cos(ωt +
    ψ)) with a ⟂ b unit vectors, ω = speed/A, as the per-component
    amplitude and phase of `Motion`."""
    a = rng.normal(size=3)
    a /= np.linalg.norm(a)
    b = rng.normal(size=3)
    b -= (b @ a) * a
    b /= np.linalg.norm(b)
    psi = rng.uniform(0.0, 2.0 * np.pi)
    return Motion(
        amplitude=[float(x) for x in radius * np.hypot(a, b)],
        angular_frequency=[speed / radius] * 3,
        phase=[float(x) for x in psi + np.arctan2(b, a)],
    )


def set_in_motion(
    scenario: sc.Scenario,
    seed: int,
    index: int,
    share: float,
    speed: float,
    workspace: Workspace = DEFAULT_WORKSPACE,
) -> sc.Scenario:
    """`scenario` (field `index` of seed `seed`) with round(share × its
    obstacle count) of its obstacles circling at `speed` m/s (see the module
    docstring); fewer where too few have room to move."""
    rng = np.random.default_rng([seed, index, MOTION_STREAM])
    needed = as_vehicle(scenario.vehicle).collision_radius + workspace.clearance
    obstacles = list(scenario.obstacles)
    wanted = round(share * len(obstacles))
    for k in rng.permutation(len(obstacles)):
        if wanted == 0:
            break
        alone = dataclasses.replace(scenario, obstacles=[obstacles[k]])
        room = min(obstacle_distances(alone, [scenario.start, scenario.goal])) - needed
        radius = min(rng.uniform(*CIRCLE_RADII), room)
        if radius < MIN_CIRCLE:
            continue
        motion = circle_motion(rng, radius, speed)
        obstacles[k] = dataclasses.replace(obstacles[k], motion=motion)
        wanted -= 1
    return dataclasses.replace(scenario, obstacles=obstacles)


def self_contained(scenario: sc.Scenario) -> sc.Scenario:
    """`scenario` with its world file's obstacles and its meshes' convex
    pieces among its own (`world_files.with_files`) and every convex mesh
    file's vertices inline
    (Drake flies the hull of either, so the geometry is the same): it then
    reads no file, and flies on any machine."""
    scenario = with_files(scenario, scenario.name)
    obstacles = []
    for obstacle in scenario.obstacles:
        shape = obstacle.shape
        if isinstance(shape, sc.Convex) and shape.file:
            points = convex_points(shape, mesh_file(scenario, shape))
            vertices = [[float(x) for x in point] for point in points]
            shape = sc.Convex(scale=shape.scale, vertices=vertices)
        obstacles.append(dataclasses.replace(obstacle, shape=shape))
    return dataclasses.replace(scenario, obstacles=obstacles, base_dir="")


def write_scenario(scenario: sc.Scenario, path: str, header: str = "") -> None:
    """Writes `scenario` as one YAML file that `load_scenario` reads back
    equal up to convex mesh files, whose vertices it holds inline
    (`self_contained`): the file flies anywhere by itself. Only fields that
    differ from the defaults are written. Atomic."""
    text = yaml_dump_typed(self_contained(scenario), defaults=sc.Scenario())
    write_text(path, header + text)
