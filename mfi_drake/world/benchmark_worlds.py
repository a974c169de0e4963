"""Seeded worlds of the two classes public navigation benchmarks fly
(issue 50), in the style of `nonconvex`'s (docs/nonconvex.md):

- "clutter": dense thin cylinders in a slab, after BARN (Perille et al.,
  "Benchmarking metric ground navigation", SSRR 2020): cylinders of radius
  `POST_RADIUS` on a jittered square grid (spacing 0.3–0.45 m, which
  alone leaves gaps narrower than the vehicle), 30–60 % of them removed
  at random, and a passage carved through (every cylinder within a drawn
  half-width of a random polyline from start to goal removed), between a
  floor box and a ceiling box `SLAB` apart and two side walls, so that the
  vehicle can neither pass over nor round the field. Start and goal 10 m
  apart at mid-height.
- "floorplan": an indoor floor plan, a maze of rooms: a grid of cells
  (2.5–3.5 m), walls `WALL_HEIGHT` tall under a ceiling on the ground, the
  cells joined by doors `DOOR_WIDTH` wide (a random spanning tree, so a
  maze with corridors of cells; a few extra doors add loops). Start in the
  cell at one corner, goal in the opposite corner's cell.

World `index` of class `kind` at seed `seed` draws from
default_rng([seed, index, BENCHMARK_STREAM, k]) (k: the class's place in
`KINDS`); a world whose start or goal has less than the vehicle's
collision radius plus `nonconvex.CLEARANCE` of room (in the slab, at most
its half-height) is redrawn, as `nonconvex`'s are. A passage exists by
construction in both: the carved one holds a disc of at least the drawn
half-width (≥ 0.35 m, the vehicle's collision radius is 0.225 m), and
every door is 1 m wide.
"""

import math

import numpy as np

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import Ground
from mfi_drake.world.nonconvex import THICKNESS, box, first_clear, wall, world_name

KINDS = ("clutter", "floorplan")
BENCHMARK_STREAM = 5  # after nonconvex's 4
DURATION = 100.0  # s, BARN's limit
POST_RADIUS = 0.075  # m, BARN's cylinders
SLAB = 1.0  # m between floor and ceiling (the flight height is its middle)
LENGTH = 10.0  # m, start to goal (clutter)
FIELD = (1.5, 8.5)  # m, the cluttered stretch of x
WIDTH = 5.0  # m between the side walls (clutter)
WALL_HEIGHT = 2.5  # m, a floor plan's walls, under its ceiling
DOOR_WIDTH = 1.0  # m
DOOR_HEIGHT = 2.1  # m
FLOOR_HEIGHT = 1.25  # m, the flight height in a floor plan


def _slab(length: float, width: float, top: float) -> list:
    """The floor (top face at z = 0) and ceiling (bottom at `top`) boxes
    and the two side walls at y = ±width/2 over x ∈ [−1, length + 1]."""
    x = length / 2
    size = [length + 2.0, width + 2 * THICKNESS, THICKNESS]
    sides = [
        box([x, s * (width + THICKNESS) / 2, top / 2], [length + 2.0, THICKNESS, top])
        for s in (-1.0, 1.0)
    ]
    return [
        box([x, 0.0, -THICKNESS / 2], size),
        box([x, 0.0, top + THICKNESS / 2], size),
        *sides,
    ]


def _clutter(rng: np.random.Generator) -> tuple:
    """(obstacles, ground, start, goal) of a "clutter" world."""
    spacing = rng.uniform(0.3, 0.45)
    removed = rng.uniform(0.3, 0.6)
    # The carved passage's half-width: BARN's widest passages admit a disc
    # of 0.365–0.5 m radius.
    half = rng.uniform(0.35, 0.5)
    xs = np.arange(FIELD[0], FIELD[1] + 1e-9, spacing)
    ys = np.arange(-WIDTH / 2 + spacing / 2, WIDTH / 2 - spacing / 4, spacing)
    posts = np.array([(x, y) for x in xs for y in ys])
    posts += rng.uniform(-0.15, 0.15, posts.shape) * spacing
    keep = rng.random(len(posts)) >= removed
    # The passage: a polyline from start to goal through a few waypoints
    # drawn across the field's width; posts within `half` + their radius
    # of it are removed.
    x_way = np.linspace(0.0, LENGTH, 5)
    y_way = np.concatenate([[0.0], rng.uniform(-1.2, 1.2, 3), [0.0]])
    line = np.column_stack([x_way, y_way])
    keep &= _segment_distance(posts, line) > half + POST_RADIUS
    cylinders = [
        sc.Obstacle(
            shape=sc.Cylinder(radius=POST_RADIUS, length=SLAB),
            position=[float(x), float(y), SLAB / 2],
        )
        for x, y in posts[keep]
    ]
    height = SLAB / 2
    return (
        _slab(LENGTH, WIDTH, SLAB) + cylinders,
        None,
        [0.0, 0.0, height],
        [LENGTH, 0.0, height],
    )


def _segment_distance(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Each point's (k, 2) distance to the polyline `line` (m, 2)."""
    best = np.full(len(points), np.inf)
    for a, b in zip(line[:-1], line[1:], strict=True):
        ab = b - a
        s = np.clip((points - a) @ ab / (ab @ ab), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(points - a - s[:, None] * ab, axis=1))
    return best


def _floorplan(rng: np.random.Generator) -> tuple:
    """(obstacles, ground, start, goal) of a "floorplan" world."""
    cols, rows = int(rng.integers(3, 5)), int(rng.integers(2, 4))
    cell = rng.uniform(2.5, 3.5)
    doors = _maze_doors(rng, cols, rows)
    obstacles = []
    # Outer walls, then each inner wall between two cells, with a door
    # where the maze joins them.
    w, h = cols * cell, rows * cell
    corners = [(0, 0), (w, 0), (w, h), (0, h)]
    for k in range(4):
        obstacles += wall(corners[k], corners[(k + 1) % 4], 0.0, WALL_HEIGHT)
    for i in range(cols):
        for j in range(rows):
            for di, dj in ((1, 0), (0, 1)):
                if i + di >= cols or j + dj >= rows:
                    continue
                a = ((i + 1) * cell, j * cell) if di else (i * cell, (j + 1) * cell)
                b = (a[0], a[1] + cell) if di else (a[0] + cell, a[1])
                holes = ()
                if frozenset({(i, j), (i + di, j + dj)}) in doors:
                    margin = THICKNESS + 0.3  # m, of wall beside the door
                    u = rng.uniform(margin, cell - margin - DOOR_WIDTH)
                    holes = ((u, u + DOOR_WIDTH, 0.0, DOOR_HEIGHT),)
                obstacles += wall(a, b, 0.0, WALL_HEIGHT, holes)
    ceiling = [w + 2 * THICKNESS, h + 2 * THICKNESS, THICKNESS]
    obstacles.append(box([w / 2, h / 2, WALL_HEIGHT + THICKNESS / 2], ceiling))
    start = [cell / 2, cell / 2, FLOOR_HEIGHT]
    goal = [w - cell / 2, h - cell / 2, FLOOR_HEIGHT]
    return obstacles, Ground(height=0.0), start, goal


def _maze_doors(rng: np.random.Generator, cols: int, rows: int) -> set:
    """The doors (frozensets of two neighbouring cells) of a maze on the
    cols × rows grid: a random depth-first spanning tree (every cell
    reachable, one way between any two), and one extra door in five of the
    others (loops)."""
    seen, stack, doors = {(0, 0)}, [(0, 0)], set()
    while stack:
        i, j = stack[-1]
        around = [
            (a, b)
            for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1))
            if 0 <= a < cols and 0 <= b < rows and (a, b) not in seen
        ]
        if not around:
            stack.pop()
            continue
        nxt = around[int(rng.integers(len(around)))]
        doors.add(frozenset({(i, j), nxt}))
        seen.add(nxt)
        stack.append(nxt)
    for i in range(cols):
        for j in range(rows):
            for nxt in ((i + 1, j), (i, j + 1)):
                if nxt[0] < cols and nxt[1] < rows and rng.random() < 0.2:
                    doors.add(frozenset({(i, j), nxt}))
    return doors


_DRAWS = {"clutter": _clutter, "floorplan": _floorplan}


def benchmark_world(
    kind: str,
    seed: int,
    index: int,
    vehicle: str = "drake_default",
    sensor: sc.Sensor | None = None,
    duration: float = DURATION,
) -> sc.Scenario:
    """World `index` of class `kind` (one of `KINDS`) at seed `seed` (see
    the module docstring)."""
    if kind not in _DRAWS:
        raise ValueError(f"world = {kind!r}: must be one of {', '.join(KINDS)}")
    rng = np.random.default_rng([seed, index, BENCHMARK_STREAM, KINDS.index(kind)])
    # The clutter slab's floor and ceiling are SLAB/2 away.
    room = SLAB / 2 if kind == "clutter" else math.inf
    name = world_name(kind, seed, index)
    return first_clear(name, rng, _DRAWS[kind], vehicle, sensor, duration, room)
