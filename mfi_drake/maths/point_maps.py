"""Point-cloud maps (a recorded cloud as the world, docs/usage.md "Point-cloud
maps"): the cloud thinned to one point a voxel, and the sphere sensor's
readings of it, grouped into obstacles as the depth camera's perception
groups its samples (`perception.voxel_graph`, `perception.nearest_basins`,
`perception.Groups`), so a map is read as a camera's memory would be.
Lengths in metres, world frame."""

import numpy as np

from mfi_drake.maths.layout import OBSTACLE_COUNT, obstacle_signal
from mfi_drake.maths.perception import DIP, Groups, nearest_basins, voxel_graph

# [m] the default edge of the voxels a map is thinned to (`Scenario.map_voxel`):
# a quarter of the perception's grouping voxel (perception.VOXEL), so thinning
# never joins or splits its groups, and well under the collision radius of
# either vehicle, so the thinned map's clearance is within it of the cloud's.
MAP_VOXEL = 0.05
# `MapReader` keeps the map's points within r_s plus this fraction of r_s
# of where it last gathered them, and gathers again when the vehicle is
# farther than that from there: a larger margin gathers less often and
# reads more points each time.
MARGIN = 0.1


def downsample(points: np.ndarray, voxel: float) -> np.ndarray:
    """(m, 3): the centroid of the points (n ≥ 1, 3) of each occupied voxel of
    edge `voxel`, in voxel order (a standard voxel-grid filter: a flat
    surface's centroids stay on it; each lies within the voxel's diagonal
    of every point it stands for)."""
    cells = np.floor(points / voxel).astype(np.int64)
    order = np.lexsort(cells.T[::-1])  # voxel by voxel, x then y then z
    cells = cells[order]
    starts = np.flatnonzero(np.any(cells[1:] != cells[:-1], axis=1)) + 1
    starts = np.concatenate([[0], starts])
    counts = np.diff(np.append(starts, len(cells)))
    return np.add.reduceat(points[order], starts, axis=0) / counts[:, None]


def map_readings(
    xyz: np.ndarray, position: np.ndarray, radius: float, count: int = OBSTACLE_COUNT
) -> np.ndarray:
    """The "obstacle" signal (`maths.layout`) at `position` of the map
    `xyz` (3, n): its points within `radius` (inclusive) grouped by the
    camera's perception, the nearest point of each of the `count`
    nearest groups, nearest first. The reading by its definition, over
    every point: `MapReader` reads the same, faster."""
    d = xyz - position[:, None]
    near = np.flatnonzero(np.einsum("ij,ij->j", d, d) <= radius * radius)
    points = xyz[:, near].T
    graph = voxel_graph(points)
    basins = nearest_basins(points, graph, position, count)
    chosen = np.zeros(graph.count, dtype=bool)
    chosen[basins] = True
    mine = chosen[graph.voxel_of]
    groups = Groups.of(points[mine], graph.voxel_of[mine])
    return obstacle_signal(groups.nearest(position), count)


def nearest_points(
    points: np.ndarray, queries: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(distances, indices), each (q,): which of `points` (n, 3, n ≥ 1) is
    nearest each query point (q, 3), and how far: a KD-tree's exact
    nearest neighbour (ties to either)."""
    from scipy.spatial import cKDTree  # imported here: only a map pays

    queries = np.asarray(queries, dtype=float).reshape(-1, 3)
    distances, index = cKDTree(points).query(queries)
    return distances, index.astype(int)


class MapReader:
    """`map_readings` of one map, the same readings bit for bit, at the
    cost of the points near the vehicle only (docs/performance.md,
    "Point-cloud maps").

    Built once: the perception's voxel graph of the whole map
    (`voxel_graph`), the map's points ordered voxel by voxel, and a
    KD-tree of them. A reading gathers the points within r_s (1 + MARGIN)
    of the position with the tree and keeps them, as runs of one voxel
    each with the graph's edges between those voxels, while the vehicle
    stays within MARGIN r_s of where it gathered them (every point within
    r_s of it is among them). Each reading then takes each voxel's nearest
    point within r_s and the voxels' persistent minima, in one compiled
    pass each (`map_kernels`).
    """

    def __init__(self, points: np.ndarray, radius: float, count: int = OBSTACLE_COUNT):
        from scipy.spatial import cKDTree  # imported here: only a map pays

        from mfi_drake.maths import map_kernels

        self._kernels = map_kernels
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        graph = voxel_graph(points)
        order = np.argsort(graph.voxel_of, kind="stable")  # map order within
        self._points = points[order]
        self._voxel_of = graph.voxel_of[order]
        # The graph's adjacency both ways (CSR: voxel v's neighbours are
        # neighbours[adjacent[v]:adjacent[v + 1]]).
        ends = np.concatenate([graph.a, graph.b])
        by_end = np.argsort(ends, kind="stable")
        self._adjacent = np.searchsorted(ends[by_end], np.arange(graph.count + 1))
        self._neighbours = np.concatenate([graph.b, graph.a])[by_end]
        self._local = np.full(graph.count, -1)  # each voxel's run, if gathered
        self._tree = cKDTree(self._points)
        self._radius = float(radius)
        self._count = int(count)  # readings a signal holds
        self._centre = None  # where the kept points were gathered

    def __call__(self, position: np.ndarray) -> np.ndarray:
        """The "obstacle" signal at `position` (`map_readings`)."""
        position = np.asarray(position, dtype=float)
        if self._centre is None or (
            np.linalg.norm(position - self._centre) > MARGIN * self._radius
        ):
            self._gather(position)
        xyz, runs, balls, voxels = self._near
        nearest, best = self._kernels.voxel_nearest(
            xyz, runs, balls, position, self._radius * self._radius
        )
        graph = (voxels, self._adjacent, self._neighbours, self._local)
        found = self._kernels.basins(nearest, graph, self._count, DIP)
        # Each basin's nearest point, nearest first, ties in voxel order (as
        # `Groups.nearest` sorts them).
        offsets = []
        for voxel in found.tolist():
            d = (xyz[:, best[voxel]] - position).tolist()
            offsets.append((d[0] * d[0] + d[1] * d[1] + d[2] * d[2], voxel, d))
        return obstacle_signal([d for _, _, d in sorted(offsets)], self._count)

    def _gather(self, position: np.ndarray) -> None:
        """Keeps the points within r_s (1 + MARGIN) of `position`: their xyz
        (3, m); where each voxel's run of them starts (and the end); each
        run's ball (centre, radius: (k, 4)); and each run's voxel, whose
        run `_local` gives (the graph's other voxels: −1)."""
        reach = self._radius * (1.0 + MARGIN)
        index = self._tree.query_ball_point(position, reach, return_sorted=True)
        index = np.asarray(index, dtype=np.int64)
        points, voxel = self._points[index], self._voxel_of[index]
        runs = np.flatnonzero(np.diff(voxel, prepend=-1))
        counts = np.diff(np.append(runs, len(index)))
        voxels = voxel[runs]  # ascending: the map's points are in voxel order
        centres = np.add.reduceat(points, runs, axis=0) / counts[:, None]
        spread = np.linalg.norm(points - np.repeat(centres, counts, axis=0), axis=1)
        balls = np.column_stack([centres, np.maximum.reduceat(spread, runs)])
        if self._centre is not None:
            self._local[self._near[3]] = -1
        self._local[voxels] = np.arange(len(voxels))
        self._near = (
            np.ascontiguousarray(points.T),
            np.append(runs, len(index)).astype(np.int64),
            balls,
            voxels,
        )
        self._centre = position.copy()
