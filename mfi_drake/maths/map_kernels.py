"""The point-cloud map's reading (`point_maps.map_readings`) compiled with
numba for `point_maps.MapReader`: one pass over the points near the
vehicle, then the voxels' persistent minima found by a flood from each
candidate (`perception.persistent_minima` labels every component of the
low voxels instead; the two agree, tests/test_point_maps.py checks it bit
for bit against the numpy reading). Imported by `MapReader` only, so that
numba's import and compilation (cached on disk) are paid by a map alone.

Distances are computed as numpy computes them in `map_readings` (each
squared distance as ((dx² + dy²) + dz²), the distance its square root,
the minimum of square roots the square root of the minimum), so the
readings are the same to the last bit.
"""

import numba
import numpy as np


@numba.njit(cache=True)
def voxel_nearest(xyz, runs, balls, position, radius2):
    """(each voxel's distance to `position`, its nearest point's column in
    xyz, −1 and inf where it holds no point within the radius): voxel k is
    columns runs[k] to runs[k + 1] − 1 of xyz (3, m), within the ball
    balls[k] (centre, radius: a voxel whose ball is beyond the radius, by
    more than rounding, is skipped); the first of equal nearest points
    (map order) wins, as numpy's argmin picks it."""
    voxels = len(runs) - 1
    nearest = np.full(voxels, np.inf)
    best = np.full(voxels, -1)
    px, py, pz = position[0], position[1], position[2]
    reach = np.sqrt(radius2) * (1.0 + 1e-9)
    for k in range(voxels):
        cx, cy, cz = balls[k, 0] - px, balls[k, 1] - py, balls[k, 2] - pz
        if np.sqrt(cx * cx + cy * cy + cz * cz) - balls[k, 3] > reach:
            continue
        # The first nearest point of all; within the radius or none is.
        least, first = np.inf, -1
        for j in range(runs[k], runs[k + 1]):
            dx, dy, dz = xyz[0, j] - px, xyz[1, j] - py, xyz[2, j] - pz
            d2 = dx * dx + dy * dy + dz * dz
            if d2 < least:
                least, first = d2, j
        if least <= radius2:
            nearest[k], best[k] = np.sqrt(least), first
    return nearest, best


@numba.njit(cache=True)
def _reaches_nearer(m, nearest, graph, level, seen, stack):
    """Whether the component of voxel m among the voxels no farther than
    `level` holds one nearer than m (a flood from m that stops there)."""
    voxels, indptr, indices, local = graph
    seen[:] = False
    seen[m] = True
    stack[0] = m
    top = 1
    while top:
        top -= 1
        v = voxels[stack[top]]
        for e in range(indptr[v], indptr[v + 1]):
            u = local[indices[e]]
            if u < 0 or seen[u] or not nearest[u] <= level:
                continue
            if nearest[u] < nearest[m]:
                return True
            seen[u] = True
            stack[top] = u
            top += 1
    return False


@numba.njit(cache=True)
def basins(nearest, graph, count, dip):
    """`perception.persistent_minima` of the voxels holding a point (those
    of finite `nearest`). graph = (voxels, indptr, indices, local): voxel
    k is the graph's node voxels[k], whose neighbours are the nodes
    indices[indptr[n]:indptr[n + 1]] of node n (CSR), each voxel local[n]
    (−1: a node not among these voxels); voxel indices order ties, as
    there."""
    voxels, indptr, indices, local = graph
    size = len(nearest)
    minimum = np.zeros(size, dtype=np.bool_)
    for v in range(size):
        if not np.isfinite(nearest[v]):
            continue
        minimum[v] = True
        for e in range(indptr[voxels[v]], indptr[voxels[v] + 1]):
            u = local[indices[e]]
            if u < 0:
                continue
            if nearest[u] < nearest[v] or (nearest[u] == nearest[v] and u < v):
                minimum[v] = False
                break
    minima = np.flatnonzero(minimum)
    order = minima[np.argsort(nearest[minima], kind="mergesort")]
    found = np.empty(min(count, len(order)), dtype=np.int64)
    seen = np.zeros(size, dtype=np.bool_)
    stack = np.empty(size, dtype=np.int64)
    k = 0
    for m in order:
        if k == len(found):
            break
        level = nearest[m] + dip
        if k and _reaches_nearer(m, nearest, graph, level, seen, stack):
            continue
        found[k] = m
        k += 1
    return found[:k]
