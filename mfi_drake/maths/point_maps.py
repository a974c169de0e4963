"""Point-cloud maps (a recorded cloud as the world, docs/usage.md "Point-cloud
maps"): the cloud thinned to one point a voxel, and the sphere sensor's
readings of it, grouped into obstacles as the depth camera's perception
groups its samples (`perception.voxel_graph`, `perception.nearest_basins`,
`perception.Groups`), so a map is read as a camera's memory would be.
Lengths in metres, world frame."""

import numpy as np

from mfi_drake.maths.layout import OBSTACLE_COUNT, obstacle_signal
from mfi_drake.maths.perception import Groups, nearest_basins, voxel_graph

# [m] the default edge of the voxels a map is thinned to (`Scenario.map_voxel`):
# a quarter of the perception's grouping voxel (perception.VOXEL), so thinning
# never joins or splits its groups, and well under the collision radius of
# either vehicle, so the thinned map's clearance is within it of the cloud's.
MAP_VOXEL = 0.05
# Pairs a chunk of `nearest_points` compares at once (memory ~ 8 bytes each).
_CHUNK = 1 << 22


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


def map_readings(xyz: np.ndarray, position: np.ndarray, radius: float) -> np.ndarray:
    """The "obstacle" signal (`maths.layout`) at `position` of the map
    `xyz` (3, n): its points within `radius` (inclusive) grouped by the
    camera's perception, the nearest point of each of the OBSTACLE_COUNT
    nearest groups, nearest first."""
    d = xyz - position[:, None]
    near = np.flatnonzero(np.einsum("ij,ij->j", d, d) <= radius * radius)
    points = xyz[:, near].T
    graph = voxel_graph(points)
    basins = nearest_basins(points, graph, position, OBSTACLE_COUNT)
    chosen = np.zeros(graph.count, dtype=bool)
    chosen[basins] = True
    mine = chosen[graph.voxel_of]
    groups = Groups.of(points[mine], graph.voxel_of[mine])
    return obstacle_signal(groups.nearest(position))


def nearest_points(
    points: np.ndarray, queries: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(distances, indices), each (q,): which of `points` (n, 3, n ≥ 1) is
    nearest each query point (q, 3), and how far. A matrix product ranks
    the candidates; the distance to the one chosen is then computed
    directly, so it is exact, and the choice is off only between points
    whose distances tie to the product's rounding (~1e-16 |q|²)."""
    queries = np.asarray(queries, dtype=float).reshape(-1, 3)
    squared = np.einsum("ij,ij->i", points, points)
    step = max(1, _CHUNK // len(points))
    index = np.concatenate(
        [
            np.argmin(squared[None, :] - 2.0 * q @ points.T, axis=1)
            for q in np.split(queries, range(step, len(queries), step))
        ]
    ).astype(int)
    return np.linalg.norm(points[index] - queries, axis=1), index
