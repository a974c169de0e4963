"""The reference path of a scenario: the shortest collision-free path of the
vehicle's centre, i.e. of a point among the obstacles grown by the vehicle's
collision radius R. A flight's path-length ratio is its path length over
this one.

How it is found (`reference_path`), when the straight line from start to
goal is not free (when it is, it is the path):

1. A* on a 26-connected 3-D grid of cell size h (default 0.1 m) over the box
   that holds the start, the goal and every grown obstacle (a shortest path
   among convex obstacles stays in their convex hull, so the box loses
   nothing). A cell is free when the exact SceneGraph distance from its
   centre to the nearest obstacle surface is ≥ R + h√3/2: the distance is
   1-Lipschitz, so the segment to any free neighbour then keeps ≥ R. Cells
   are classified lazily, as A* reaches them.
2. Shortcutting: greedy string pulling on the grid path, every segment
   checked exactly by sphere tracing.
3. Tightening, coarse to fine: the polyline is resampled at spacing
   s = 0.4, 0.2, 0.1, 0.05 m and relaxed by Gauss–Seidel sweeps that move each
   point to the midpoint of its neighbours and push it back out to distance
   R along the distance gradient: the discrete taut string.

How close to the true optimum: the result is a feasible path up to the
chords of the grown surfaces (each point keeps distance ≥ R, a chord of
length s on a surface of curvature radius ρ dips s²/8ρ ≤ 1 mm inside), so
it is an upper bound on the optimum up to the chords' length deficit
(≲ s²/24ρ², below 0.05 %). Against closed forms (a sphere on the line,
a wall, tests/test_sweep.py) it is within 0.002 % of the optimum (the
tests allow 0.1 %); the grid path alone is 9–21 % long, the shortcut one
0.3–0.7 %. It finds the best path of the homotopy classes the grid sees: a
gap between grown obstacles narrower than h√3 ≈ 0.17 m can be missed,
making the reference longer than the optimum.
"""

import heapq
import itertools
import math
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import SceneGraph

from mfi_drake.config import scenario as sc
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.world.obstacles import register_obstacles
from mfi_drake.world.shapes import bounding_radius

TIGHTEN_SPACINGS = (0.4, 0.2, 0.1, 0.05)  # m, step 3's resampling spacings
SURFACE_TOLERANCE = 2e-3  # m, how far a chord may dip into a grown obstacle


class Clearance:
    """Exact distances from points to the obstacles grown by `radius`, from one
    SceneGraph built once (for the many queries of a path search)."""

    def __init__(self, scenario: sc.Scenario, radius: float):
        self.radius = radius
        self._scene_graph = SceneGraph()
        frames = register_obstacles(self._scene_graph, scenario)
        self._context = self._scene_graph.CreateDefaultContext()
        frames.fix(self._scene_graph, self._context, 0.0)  # moving ones: at t = 0
        self._query = self._scene_graph.get_query_output_port().Eval(self._context)

    def closest(self, p, reach: float) -> tuple[float, np.ndarray]:
        """(clearance d − R, outward unit gradient) of the nearest grown
        obstacle, or (reach, 0) when none is within `reach` of the grown
        surfaces; p a 3-vector or a list of its entries."""
        results = self._query.ComputeSignedDistanceToPoint(p, self.radius + reach)
        if not results:
            return reach, np.zeros(3)
        best = min(results, key=lambda r: r.distance)
        return best.distance - self.radius, best.grad_W

    def segment_free(self, a: np.ndarray, b: np.ndarray, tolerance: float) -> bool:
        """True when every point of segment ab keeps clearance ≥ −tolerance,
        by sphere tracing: at a point with clearance c the next c + tolerance
        metres are free (the distance is 1-Lipschitz)."""
        length = float(np.linalg.norm(b - a))
        t = 0.0
        while True:
            p = a + (b - a) * (t / length) if length > 0 else a
            step = self.closest(p, 1.0)[0] + tolerance
            if step < 1e-4:
                return False
            t += step
            if t >= length:
                # b itself: the step from the last point may end short of it.
                return self.closest(b, 1.0)[0] + tolerance >= 0.0

    def blocked_fraction(self, a: np.ndarray, b: np.ndarray, step: float) -> float:
        """Fraction of segment ab inside grown obstacles (sampled every `step`).

        Each query's clearance c also settles the samples after it that are
        nearer than |c| (the distance is 1-Lipschitz: they are on the same
        side), so far from the surfaces one query stands for many samples."""
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
        points = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
        spacing = float(np.linalg.norm(b - a)) / (n - 1)
        inside, k = 0, 0
        while k < n:
            c = self.closest(points[k], 1.0)[0]
            # Samples k .. k + same − 1 are within |c| of sample k (with a
            # margin for the rounding of their positions).
            same = 1 + max(0, math.ceil((abs(c) - 1e-9) / spacing) - 1)
            same = min(same, n - k)
            inside += same if c < 0.0 else 0
            k += same
        return inside / n


@dataclass
class ReferencePath:
    points: np.ndarray  # (N, 3), start to goal
    length: float  # m, of `points` (after step 3)
    grid_length: float  # m, of the A* path (step 1)
    shortcut_length: float  # m, after step 2


def polyline_length(points: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


# The 26 neighbours of a cell and the length of the step to each, in cells.
_NEIGHBOURS = [
    (d, math.sqrt(sum(x * x for x in d)))
    for d in itertools.product((-1, 0, 1), repeat=3)
    if d != (0, 0, 0)
]


def _grid_distance(a: tuple, b: tuple) -> float:
    """Exact 26-connected grid distance in free space, in cells (A*'s
    admissible, consistent heuristic)."""
    d1, d2, d3 = sorted(abs(x - y) for x, y in zip(a, b, strict=True))
    return math.sqrt(3) * d1 + math.sqrt(2) * (d2 - d1) + (d3 - d2)


def grid_path(
    clearance: Clearance,
    start: np.ndarray,
    goal: np.ndarray,
    low: np.ndarray,
    shape: tuple[int, int, int],
    cell: float,
) -> np.ndarray:
    """Step 1: cell centres of the shortest 26-connected grid path from the
    cell holding `start` to the one holding `goal`, start and goal included."""
    margin = cell * math.sqrt(3) / 2
    known: dict[tuple, bool] = {}

    def free(c: tuple) -> bool:
        if c not in known:
            centre = low + (np.asarray(c) + 0.5) * cell
            known[c] = clearance.closest(centre, margin)[0] >= margin
        return known[c]

    def cell_of(p):
        return tuple(int(x) for x in np.floor((p - low) / cell))

    source, target = cell_of(start), cell_of(goal)
    for name, c in (("start", source), ("goal", target)):
        if not free(c):
            raise ValueError(
                f"{name}'s grid cell is within {margin:.3f} m of an obstacle"
            )
    best = {source: 0.0}
    parent = {source: None}
    heap = [(_grid_distance(source, target), 0.0, source)]
    done = set()
    while heap:
        _, g, c = heapq.heappop(heap)
        if c == target:
            break
        if c in done:
            continue
        done.add(c)
        for d, step in _NEIGHBOURS:
            n = (c[0] + d[0], c[1] + d[1], c[2] + d[2])
            if not all(0 <= n[i] < shape[i] for i in range(3)) or n in done:
                continue
            g_n = g + step
            if g_n < best.get(n, math.inf) and free(n):
                best[n], parent[n] = g_n, c
                # Ties broken toward the deeper node (−g_n) to cut plateaus.
                heapq.heappush(heap, (g_n + _grid_distance(n, target), -g_n, n))
    else:
        raise ValueError("no collision-free path inside the grid")
    cells = []
    c = target
    while c is not None:
        cells.append(c)
        c = parent[c]
    centres = low + (np.array(cells[::-1], float) + 0.5) * cell
    return np.vstack([start, centres[1:-1], goal])


def shortcut(clearance: Clearance, points: np.ndarray) -> np.ndarray:
    """Step 2: from each kept point, jump to the farthest point it sees."""
    kept, i = [points[0]], 0
    while i < len(points) - 1:
        j = len(points) - 1
        while j > i + 1 and not clearance.segment_free(points[i], points[j], 0.0):
            j -= 1
        kept.append(points[j])
        i = j
    return np.array(kept)


def resample(points: np.ndarray, spacing: float) -> np.ndarray:
    """The polyline through `points`, sampled at equal arc length ≤ spacing."""
    s = np.concatenate(
        [[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]
    )
    n = max(2, int(np.ceil(s[-1] / spacing)) + 1)
    t = np.linspace(0.0, s[-1], n)
    return np.column_stack([np.interp(t, s, points[:, k]) for k in range(3)])


def tighten(
    clearance: Clearance, points: np.ndarray, spacing: float, sweeps: int = 400
) -> np.ndarray:
    """Step 3 at one spacing: Gauss–Seidel midpoint sweeps, each point pushed
    back out to clearance 0 along the gradient, until nothing moves 0.1 mm."""
    # On lists of Python floats: numpy on single 3-vectors costs more than
    # the arithmetic, and a field's reference takes ~10⁵ of these updates.
    p = resample(points, spacing).tolist()
    # A lower bound on each point's clearance: the distance is 1-Lipschitz,
    # so a point that moves less than its bound stays free without a query
    # (the result is the same; most points are far from every obstacle).
    free = [-math.inf] * len(p)
    for _ in range(sweeps):
        moved = 0.0
        for i in range(1, len(p) - 1):
            a, b = p[i - 1], p[i + 1]
            m = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])]
            d = [m[k] - p[i][k] for k in range(3)]
            step = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
            if free[i] - step >= 0.0:
                free[i] -= step
            else:
                for _ in range(3):  # overlapping obstacles may need a few pushes
                    c, grad = clearance.closest(m, spacing)
                    if c >= 0.0:
                        break
                    m = [m[k] - c * grad[k] for k in range(3)]
                # After a push m lies on a surface: clearance ~0, no margin.
                free[i] = c if c >= 0.0 else -math.inf
                d = [m[k] - p[i][k] for k in range(3)]
                step = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
            moved = max(moved, step)
            p[i] = m
        if moved < 1e-4:
            break
    return np.array(p)


def reference_path(scenario: sc.Scenario, cell: float = 0.1) -> ReferencePath:
    """The shortest collision-free path of the vehicle's centre (steps 1–3 of
    the module docstring). Raises ValueError if the grid has no path."""
    radius = as_vehicle(scenario.vehicle).collision_radius
    clearance = Clearance(scenario, radius)
    start = np.asarray(scenario.start, float)
    goal = np.asarray(scenario.goal, float)
    if clearance.segment_free(start, goal, 0.0):
        # The straight line is the shortest of all paths: steps 1–3 would
        # only find it again.
        line = np.array([start, goal])
        length = polyline_length(line)
        return ReferencePath(line, length, length, length)
    corners = [start, goal]
    for obstacle in scenario.obstacles:
        reach = bounding_radius(scenario, obstacle.shape) + radius
        centre = np.asarray(obstacle.position, float)
        corners += [centre - reach, centre + reach]
    low = np.min(corners, axis=0) - 2 * cell
    high = np.max(corners, axis=0) + 2 * cell
    shape = tuple(int(x) for x in np.ceil((high - low) / cell))
    coarse = grid_path(clearance, start, goal, low, shape, cell)
    pulled = shortcut(clearance, coarse)
    tight = pulled
    for spacing in TIGHTEN_SPACINGS:
        tight = tighten(clearance, tight, spacing)
    if not all(
        clearance.segment_free(a, b, SURFACE_TOLERANCE)
        for a, b in zip(tight[:-1], tight[1:], strict=True)
    ):
        tight = pulled  # never seen; the shortcut path is feasible by construction
    return ReferencePath(
        points=tight,
        length=polyline_length(tight),
        grid_length=polyline_length(coarse),
        shortcut_length=polyline_length(pulled),
    )
