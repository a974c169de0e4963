"""Open, flat and non-manifold meshes (single-sided walls, terrain, scans)
as the surfaces they are: a closed mesh encloses a volume that CoACD cuts
into convex pieces (`world.decomposition`), but an open one has no inside.

Its triangles are grouped into patches, each near-planar (every vertex
within THICKNESS/2 of the patch's first triangle's plane) and convex (the
patch's outline is its own hull: a notch such as a wall's door is never
filled), and each patch flies as a thin convex slab: the hull of its
vertices moved THICKNESS/2 along the plane's normal both ways. SceneGraph
queries a slab as any convex piece; the slab's surface lies within
THICKNESS of the mesh's (half the slab, plus the patch's flatness), and a
patch joins many triangles into one piece (a flat wall of any number of
triangles is one piece a convex region), which keeps a scene's piece count
down. docs/usage.md, "Meshes of any shape", says why slabs.
"""

from collections import deque

import numpy as np

# [m] a slab's thickness: thin beside either vehicle's collision radius
# (≥ 0.225 m), so a wall's slab is the wall to well within the clearance
# margins, and thick enough for Drake's hull of a slab to be well-conditioned.
THICKNESS = 0.02
# Triangles a patch holds at most: its convexity test costs a 2-D hull of its
# vertices per triangle tried, so a patch's cost grows as its size squared.
MAX_PATCH = 256
_AREA_SLACK = 1e-6  # relative: a hull this much larger than the patch is convex


def closed(triangles: np.ndarray) -> bool:
    """Whether the mesh is closed and consistently oriented: each directed
    edge once, and its reverse once (a 2-manifold without boundary)."""
    t = np.asarray(triangles)
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    unique, counts = np.unique(directed, axis=0, return_counts=True)
    if (counts != 1).any():
        return False
    keys = unique[:, 0] * (t.max() + 1) + unique[:, 1]
    reverse = unique[:, 1] * (t.max() + 1) + unique[:, 0]
    return bool(np.isin(reverse, keys).all())


def _neighbours(triangles: np.ndarray) -> list[list[int]]:
    """For each triangle, the triangles sharing an edge with it."""
    edges = np.sort(
        np.concatenate(
            [triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]
        ),
        axis=1,
    )
    owner = np.tile(np.arange(len(triangles)), 3)
    order = np.lexsort(edges.T[::-1])
    edges, owner = edges[order], owner[order]
    same = np.flatnonzero((edges[1:] == edges[:-1]).all(axis=1))
    found: list[list[int]] = [[] for _ in range(len(triangles))]
    for k in same:  # runs of one edge: each pair in it neighbours
        a, b = int(owner[k]), int(owner[k + 1])
        if a != b:
            found[a].append(b)
            found[b].append(a)
    return found


def _cross2(u: np.ndarray, v: np.ndarray) -> float:
    """The z of the cross product of two plane vectors."""
    return float(u[0] * v[1] - u[1] * v[0])


def _hull_area(points: np.ndarray) -> float:
    """The area of the 2-D hull of `points` (k, 2) (monotone chain)."""
    p = np.unique(points, axis=0)
    if len(p) < 3:
        return 0.0

    def chain(points):
        out = []
        for q in points:
            while len(out) >= 2 and _cross2(out[-1] - out[-2], q - out[-2]) <= 0:
                out.pop()
            out.append(q)
        return out

    hull = np.array(chain(p)[:-1] + chain(p[::-1])[:-1])
    x, y = hull[:, 0], hull[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def surface_patches(
    vertices: np.ndarray,
    triangles: np.ndarray,
    flatness: float = THICKNESS / 2,
    limit: int | None = None,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """(triangle indices, unit normal) of each patch (see the module's
    docstring): grown from each triangle not yet in one, largest first,
    over shared edges, by the triangles whose vertices lie within
    `flatness` of its plane and that keep its outline convex; past
    `limit` patches, the first limit + 1. Triangles of no area are left
    out (they add no surface)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    cross = np.cross(b - a, c - a)
    double_area = np.linalg.norm(cross, axis=1)
    tiny = 1e-12 * max(float(np.ptp(vertices)), 1e-9) ** 2
    normals = cross / np.maximum(double_area, tiny)[:, None]
    neighbours = _neighbours(triangles)
    taken = double_area <= tiny
    patches = []
    for seed in np.argsort(-double_area, kind="stable"):
        if taken[seed]:
            continue
        if limit is not None and len(patches) > limit:
            break
        n, origin = normals[seed], a[seed]
        u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        basis = np.stack([u, np.cross(n, u)], axis=1)  # (3, 2): the plane's axes
        members, area = [seed], double_area[seed] / 2
        outline = (vertices[triangles[seed]] - origin) @ basis
        taken[seed] = True
        queue = deque(neighbours[seed])
        while queue and len(members) < MAX_PATCH:
            t = queue.popleft()
            if taken[t]:
                continue
            corners = vertices[triangles[t]] - origin
            if np.abs(corners @ n).max() > flatness:
                continue
            flat = corners @ basis
            projected = 0.5 * abs(_cross2(flat[1] - flat[0], flat[2] - flat[0]))
            grown = np.vstack([outline, flat])
            if _hull_area(grown) > (area + projected) * (1 + _AREA_SLACK):
                continue  # the outline would lose its convexity
            members.append(t)
            area += projected
            outline = grown
            taken[t] = True
            queue.extend(neighbours[t])
        patches.append((np.array(members), n))
    return patches


def welded(
    vertices: np.ndarray, triangles: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The mesh with equal corners (to a nanometre) made one and the
    triangles that lose a corner by it left out: OBJ exporters repeat a
    corner for each of its normals or texture coordinates, STL for each
    face, which leaves a closed surface looking open."""
    vertices, index = np.unique(np.round(vertices, 9), axis=0, return_inverse=True)
    t = index.reshape(-1)[triangles]
    kept = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 2] != t[:, 0])
    return vertices, t[kept] if kept.any() else t


def surface_slabs(
    vertices: np.ndarray,
    triangles: np.ndarray,
    thickness: float = THICKNESS,
    limit: int | None = None,
) -> list[np.ndarray]:
    """The vertices (2k, 3) of each patch's slab (`surface_patches`): its
    k vertices moved ±thickness/2 along its normal; past `limit` slabs,
    the first limit + 1 (the caller flies the mesh otherwise). Raises
    ValueError, one line, for a mesh of no surface."""
    # Shared edges: a file that repeats each face's corners has none.
    vertices, triangles = welded(
        np.asarray(vertices, dtype=float), np.asarray(triangles, dtype=np.int64)
    )
    slabs = []
    patches = surface_patches(vertices, triangles, thickness / 2, limit)
    for members, normal in patches:
        corners = vertices[np.unique(triangles[members])]
        offset = 0.5 * thickness * normal
        slabs.append(np.vstack([corners + offset, corners - offset]))
    if not slabs:
        raise ValueError("has no surface: every triangle has zero area")
    return slabs
