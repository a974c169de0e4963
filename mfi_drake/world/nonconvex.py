"""Seeded non-convex worlds: rooms, cups, walls with windows, corridors and
caves (docs/nonconvex.md), in the style of `generator`'s random fields.

Every world is one self-contained scenario built of the scenario's own
shapes (boxes, spheres), world frame, z up, lengths in metres. The start is
`START` = (0, 0, h); the goal lies about `LENGTH` = 10 m along +x (h = 1.5
where a class stands on the ground `ground: {height: 0.0}`, else 2). World
`index` of class `kind` at seed `seed` draws from
default_rng([seed, index, NONCONVEX_STREAM, k]) with k the class's place in
`KINDS`, so a world is reproducible and the classes are independent.

The classes (`KINDS`), each named for what it asks of a navigator:

- "room_exit": the start inside a closed room (four walls, a ceiling, the
  ground) whose only door, in a side wall, faces any way; the goal outside.
- "room_entry": the same room round the goal; the start outside.
- "cup": a floating five-sided box open on one face (a cup), in a random
  orientation; half the cups open toward the start (±45°), the hard case
  (the goal attraction pulls the vehicle into the bottom).
- "window_wall": a wide wall on the ground across the start–goal line with
  one window; the way through is the window or the long way round.
- "bent_corridor": a closed corridor (ground, ceiling, capped ends) with one
  or two right-angle bends and baffles (plates from alternate walls), the
  start at one end and the goal at the other.
- "cave": a cluster of overlapping spheres on a spherical shell, a pocket
  with its mouth toward the start (±45°), between start and goal.

A world whose start or goal is closer than the vehicle's collision radius
plus `CLEARANCE` to an obstacle (exact SceneGraph distance) is redrawn from
the same stream. `sealed_room` is a room without a door round the goal: a
goal nothing can reach.
"""

import math

import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import Ground
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.world.generator import random_rpy_deg
from mfi_drake.world.obstacles import obstacle_distances

KINDS = ("room_exit", "room_entry", "cup", "window_wall", "bent_corridor", "cave")
NONCONVEX_STREAM = 4  # after generator's streams 1–3
LENGTH = 10.0  # m, the start–goal distance along +x (the corridor's is its own)
CLEARANCE = 0.4  # m, room round start and goal beyond the collision radius
DURATION = 120.0  # s of simulated time (the issue's)
THICKNESS = 0.2  # m, walls, ceilings and plates
GROUND_HEIGHT = 1.5  # m, the flight height over the ground
FREE_HEIGHT = 2.0  # m, the flight height without ground


def world_name(kind: str, seed: int, index: int) -> str:
    return f"{kind}_s{seed}_i{index}"


def box(centre, size, yaw_deg: float = 0.0, rpy_deg=None) -> sc.Obstacle:
    """A box obstacle of `size` (x, y, z) at `centre`, yawed about z."""
    return sc.Obstacle(
        shape=sc.Box(size=[float(s) for s in size]),
        position=[float(c) for c in centre],
        rpy_deg=list(rpy_deg) if rpy_deg is not None else [0.0, 0.0, float(yaw_deg)],
    )


def wall(a, b, z0: float, z1: float, holes=(), thickness: float = THICKNESS) -> list:
    """A vertical wall of boxes along the horizontal segment a → b from
    height z0 to z1, extended by thickness/2 at both ends (so that walls
    meeting at a corner close it), with rectangular `holes` (u0, u1, h0,
    h1): u along the wall from a, h the height; holes must not overlap in
    u. Each hole leaves the pieces below and above it."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    length = float(np.linalg.norm(b - a))
    along = (b - a) / length
    yaw = math.degrees(math.atan2(along[1], along[0]))
    half = thickness / 2

    def piece(u0, u1, h0, h1):
        if u1 - u0 <= 1e-9 or h1 - h0 <= 1e-9:
            return []
        mid = a + along * (u0 + u1) / 2
        return [
            box([mid[0], mid[1], (h0 + h1) / 2], [u1 - u0, thickness, h1 - h0], yaw)
        ]

    out, u = [], -half
    for u0, u1, h0, h1 in sorted(holes):
        out += piece(u, u0, z0, z1) + piece(u0, u1, z0, h0) + piece(u0, u1, h1, z1)
        u = u1
    return out + piece(u, length + half, z0, z1)


def _rotate(yaw_deg: float, xy) -> np.ndarray:
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    x, y = xy
    return np.array([c * x - s * y, s * x + c * y])


def room(
    centre, width, depth, height, yaw_deg, door_side, door, door_width, door_height
) -> list:
    """A closed room on the ground (z = 0): four walls of inner size width ×
    depth (x × y before the yaw about its centre), a ceiling at `height`,
    and one door in wall `door_side` (0: +x, 1: +y, 2: −x, 3: −y) at `door`
    ∈ (0, 1) along it, of door_width × door_height; no door where
    door_side is None."""
    cx, cy = centre
    w, d = width / 2 + THICKNESS / 2, depth / 2 + THICKNESS / 2
    # Corners counter-clockwise from (+x, −y): wall k runs corner k → k+1.
    corners = [(w, -d), (w, d), (-w, d), (-w, -d)]
    out = []
    for k in range(4):
        a = _rotate(yaw_deg, corners[k]) + (cx, cy)
        b = _rotate(yaw_deg, corners[(k + 1) % 4]) + (cx, cy)
        holes = ()
        if door_side == k:
            span = float(np.linalg.norm(b - a))
            u = THICKNESS + door_width / 2 + door * (span - 2 * THICKNESS - door_width)
            holes = ((u - door_width / 2, u + door_width / 2, 0.0, door_height),)
        out += wall(a, b, 0.0, height, holes)
    ceiling = [2 * w + THICKNESS, 2 * d + THICKNESS, THICKNESS]
    return out + [box([cx, cy, height + THICKNESS / 2], ceiling, yaw_deg)]


def _room_draw(rng: np.random.Generator, centre, sealed: bool = False) -> list:
    width, depth = rng.uniform(4.0, 8.0, size=2)
    height = rng.uniform(2.6, 4.0)
    return room(
        centre,
        width,
        depth,
        height,
        yaw_deg=rng.uniform(-45.0, 45.0),
        door_side=None if sealed else int(rng.integers(4)),
        door=rng.uniform(0.0, 1.0),
        door_width=rng.uniform(1.0, 1.6),
        door_height=rng.uniform(2.0, min(2.4, height - 0.3)),
    )


def _room_exit(rng: np.random.Generator) -> tuple:
    offset = rng.uniform(-1.0, 1.0, size=2)
    return _room_draw(rng, offset), True, [LENGTH, 0.0, GROUND_HEIGHT]


def _room_entry(rng: np.random.Generator, sealed: bool = False) -> tuple:
    centre = rng.uniform(-1.0, 1.0, size=2) + (LENGTH, 0.0)
    return _room_draw(rng, centre, sealed), True, [LENGTH, 0.0, GROUND_HEIGHT]


def cup(centre, inner, rpy_deg) -> list:
    """A five-sided box (a cup) of inner size `inner` (depth along its x,
    width, height) open on its −x face (the mouth), posed by `rpy_deg`
    about `centre`."""
    depth, width, height = inner
    t = THICKNESS
    parts = [  # (centre, size) in the cup's frame
        ((depth / 2 + t / 2, 0, 0), (t, width + 2 * t, height + 2 * t)),  # bottom
        ((0, width / 2 + t / 2, 0), (depth, t, height + 2 * t)),
        ((0, -width / 2 - t / 2, 0), (depth, t, height + 2 * t)),
        ((0, 0, height / 2 + t / 2), (depth, width, t)),
        ((0, 0, -height / 2 - t / 2), (depth, width, t)),
    ]
    R = RotationMatrix(RollPitchYaw(np.radians(rpy_deg)))
    return [
        box(np.asarray(centre) + R.multiply(np.asarray(c, float)), s, rpy_deg=rpy_deg)
        for c, s in parts
    ]


def toward_start_rpy(rng: np.random.Generator) -> list:
    """Roll, pitch, yaw [deg] turning the local −x axis (a mouth) toward −x
    (a start on the −x side): yaw and pitch within ±45°, any roll."""
    yaw = rng.uniform(-45.0, 45.0)
    pitch = rng.uniform(-45.0, 45.0)
    roll = rng.uniform(-180.0, 180.0)
    return [float(roll), float(pitch), float(yaw)]


def _cup(rng: np.random.Generator) -> tuple:
    inner = [rng.uniform(2.0, 4.0), rng.uniform(2.5, 5.0), rng.uniform(2.5, 5.0)]
    hard = rng.uniform() < 0.5
    rpy = toward_start_rpy(rng) if hard else random_rpy_deg(rng)
    centre = [rng.uniform(4.5, 5.5), rng.uniform(-0.5, 0.5), FREE_HEIGHT]
    return cup(centre, inner, rpy), False, [LENGTH, 0.0, FREE_HEIGHT]


def _window_wall(rng: np.random.Generator) -> tuple:
    span, height = rng.uniform(16.0, 30.0), rng.uniform(4.0, 8.0)
    yaw = rng.uniform(-30.0, 30.0)
    x = rng.uniform(4.0, 6.0)
    window_width, window_height = rng.uniform(1.0, 2.0), rng.uniform(1.0, 2.0)
    sill = rng.uniform(0.5, 2.5 - window_height / 2)
    # The window's middle lies within ±3 m of the line's crossing.
    across = rng.uniform(-3.0, 3.0)
    direction = _rotate(yaw, (0.0, 1.0))
    a = np.array([x, 0.0]) - direction * span / 2
    b = np.array([x, 0.0]) + direction * span / 2
    u = span / 2 + across
    hole = (u - window_width / 2, u + window_width / 2, sill, sill + window_height)
    thickness = rng.uniform(0.2, 0.4)
    walls = wall(a, b, 0.0, height, [hole], thickness)
    return walls, True, [LENGTH, 0.0, GROUND_HEIGHT]


def corridor_centreline(rng: np.random.Generator) -> np.ndarray:
    """The corner points of a corridor's centreline in the plane: along +x,
    then one (an L) or two (a Z or a U-turn's half) right-angle bends."""
    first = rng.uniform(3.0, 6.0)
    side = rng.choice([-1.0, 1.0])
    if rng.uniform() < 0.5:  # L: +x then ±y
        return np.array([[0.0, 0.0], [first, 0.0], [first, side * rng.uniform(4, 7)]])
    shift = side * rng.uniform(3.0, 5.0)
    last = first + rng.uniform(3.0, 6.0)
    return np.array([[0.0, 0.0], [first, 0.0], [first, shift], [last, shift]])


def corridor(points, width, height, baffles, rng) -> list:
    """A closed corridor on the ground along the polyline `points` (corners
    at right angles): walls on both sides (mitred at the bends), capped
    ends 1 m beyond the first and last points, a ceiling over each
    segment, and `baffles` plates from alternate walls across 40 % of the
    width, in the segments' middles."""
    points = np.asarray(points, float)
    ends = points.copy()
    for i, j in ((0, 1), (-1, -2)):
        u = (points[i] - points[j]) / np.linalg.norm(points[i] - points[j])
        ends[i] = points[i] + 1.0 * u
    segments = np.diff(ends, axis=0)
    units = segments / np.linalg.norm(segments, axis=1)[:, None]
    normals = np.stack([-units[:, 1], units[:, 0]], axis=1)  # to the left
    out = []
    half = width / 2 + THICKNESS / 2
    for sign in (1.0, -1.0):
        offset = [ends[0] + sign * half * normals[0]]
        for k in range(1, len(ends) - 1):  # mitre: the two offset lines meet
            offset.append(ends[k] + sign * half * (normals[k - 1] + normals[k]))
        offset.append(ends[-1] + sign * half * normals[-1])
        for a, b in zip(offset[:-1], offset[1:], strict=True):
            out += wall(a, b, 0.0, height)
    for i, u in ((0, units[0]), (-1, -units[-1])):
        cap = ends[i] - u * THICKNESS / 2
        n = np.array([-u[1], u[0]])
        out += wall(cap - half * n, cap + half * n, 0.0, height)
    for a, b in zip(ends[:-1], ends[1:], strict=True):
        mid = (a + b) / 2
        yaw = math.degrees(math.atan2(*(b - a)[::-1]))
        size = [np.linalg.norm(b - a) + 2 * half, 2 * half + THICKNESS, THICKNESS]
        out.append(box([*mid, height + THICKNESS / 2], size, yaw))
    side = 1.0
    for k in range(baffles):
        s = k % len(segments)
        at = ends[s] + segments[s] * rng.uniform(0.35, 0.65)
        root = at + side * half * normals[s]
        tip = at + side * (half - 0.4 * width) * normals[s]
        out += wall(root, tip, 0.0, height)
        side = -side
    return out


def _bent_corridor(rng: np.random.Generator) -> tuple:
    points = corridor_centreline(rng)
    width, height = rng.uniform(1.8, 2.6), rng.uniform(2.6, 3.4)
    baffles = int(rng.integers(0, 3))
    walls = corridor(points, width, height, baffles, rng)
    return walls, True, [*points[-1], GROUND_HEIGHT]


def cave(centre, radius, rock, mouth_deg, axis, rng) -> list:
    """Overlapping spheres of radius ≈ `rock` (±20 %) centred on a sphere
    of `radius` + 0.7·rock about `centre`, on a Fibonacci lattice of
    directions about 1.3·rock apart (neighbours overlap), except those
    within `mouth_deg` of the unit `axis` (the mouth): a pocket of inner
    radius ≈ `radius`."""
    shell = radius + 0.7 * rock
    count = max(12, int(4 * math.pi * shell**2 / (1.3 * rock) ** 2))
    golden = math.pi * (3.0 - math.sqrt(5.0))
    out = []
    for k in range(count):
        z = 1 - 2 * (k + 0.5) / count
        r = math.sqrt(1 - z * z)
        d = np.array([r * math.cos(golden * k), r * math.sin(golden * k), z])
        if d @ axis > math.cos(math.radians(mouth_deg)):
            continue
        size = rock * rng.uniform(0.8, 1.2)
        out.append(
            sc.Obstacle(
                shape=sc.Sphere(radius=float(size)),
                position=[float(c) for c in centre + shell * d],
            )
        )
    return out


def _cave(rng: np.random.Generator) -> tuple:
    radius, rock = rng.uniform(1.2, 2.0), rng.uniform(1.0, 1.5)
    mouth = rng.uniform(35.0, 60.0)
    yaw, pitch = np.radians(rng.uniform(-45.0, 45.0, size=2))
    axis = -np.array(
        [
            math.cos(yaw) * math.cos(pitch),
            math.sin(yaw) * math.cos(pitch),
            math.sin(pitch),
        ]
    )
    centre = np.array([rng.uniform(4.5, 5.5), rng.uniform(-0.5, 0.5), FREE_HEIGHT])
    return (
        cave(centre, radius, rock, mouth, axis, rng),
        False,
        [LENGTH, 0.0, FREE_HEIGHT],
    )


_DRAWS = {
    "room_exit": _room_exit,
    "room_entry": _room_entry,
    "cup": _cup,
    "window_wall": _window_wall,
    "bent_corridor": _bent_corridor,
    "cave": _cave,
}


def nonconvex_world(
    kind: str,
    seed: int,
    index: int,
    vehicle: str = "drake_default",
    sensor: sc.Sensor | None = None,
    duration: float = DURATION,
) -> sc.Scenario:
    """World `index` of class `kind` (one of `KINDS`) at seed `seed` (see the
    module docstring)."""
    if kind not in _DRAWS:
        raise ValueError(f"world = {kind!r}: must be one of {', '.join(KINDS)}")
    rng = np.random.default_rng([seed, index, NONCONVEX_STREAM, KINDS.index(kind)])
    name = world_name(kind, seed, index)
    return _first_clear(name, rng, _DRAWS[kind], vehicle, sensor, duration)


def sealed_room(seed: int, index: int, vehicle: str = "drake_default") -> sc.Scenario:
    """World `index` of "room_entry" at seed `seed` with no door: a goal
    inside a closed box, which nothing can reach (drawn from the same
    stream, so the room is the entry world's where its first draw was
    clear)."""
    rng = np.random.default_rng(
        [seed, index, NONCONVEX_STREAM, KINDS.index("room_entry")]
    )
    name = "sealed_" + world_name("room_entry", seed, index)

    def draw(rng):
        return _room_entry(rng, sealed=True)

    return _first_clear(name, rng, draw, vehicle, None, DURATION)


def _first_clear(name, rng, draw, vehicle, sensor, duration) -> sc.Scenario:
    """`first_clear` of a draw(rng) = (obstacles, on_ground, goal) started at
    the origin, at GROUND_HEIGHT over the ground or FREE_HEIGHT without."""

    def placed(rng):
        obstacles, on_ground, goal = draw(rng)
        ground = Ground(height=0.0) if on_ground else None
        start = [0.0, 0.0, GROUND_HEIGHT if on_ground else FREE_HEIGHT]
        return obstacles, ground, start, goal

    return first_clear(name, rng, placed, vehicle, sensor, duration)


def first_clear(
    name: str,
    rng: np.random.Generator,
    draw,
    vehicle: str,
    sensor: sc.Sensor | None,
    duration: float,
    room: float = math.inf,
) -> sc.Scenario:
    """The first world of `draw(rng)` = (obstacles, ground, start, goal)
    whose start and goal have the vehicle's collision radius plus CLEARANCE
    of room (at most `room` [m])."""
    needed = min(as_vehicle(vehicle).collision_radius + CLEARANCE, room)
    while True:
        obstacles, ground, start, goal = draw(rng)
        scenario = sc.Scenario(
            name=name,
            start=[float(s) for s in start],
            goal=[float(g) for g in goal],
            duration=duration,
            vehicle=vehicle,
            sensor=sensor if sensor is not None else sc.SphereSensor(),
            obstacles=obstacles,
            ground=ground,
        )
        if min(obstacle_distances(scenario, [scenario.start, scenario.goal])) >= needed:
            return scenario
