"""Meshes of any shape: a mesh (`!Mesh`, or a mesh geometry of a `world:`
file) in any format `world.mesh_files` reads flies as convex pieces, each an
inline `!Convex` at the mesh's pose: a closed mesh as the pieces CoACD
decomposes it into (docs/usage.md, "Meshes of any shape", has the
comparison with V-HACD that chose CoACD), an open, flat or non-manifold one
as thin slabs over its surface (`world.surfaces`).

Decomposing costs seconds; the pieces are cached on disk under the user's
cache directory, keyed by the mesh's vertices and triangles and by the
decomposition's parameters, so a second flight does not pay again. A
scenario's meshes are decomposed in parallel first, a process a core
(`prefetch_pieces`), each filling the cache that `mesh_obstacles` then
reads.
"""

import concurrent.futures
import contextlib
import dataclasses
import hashlib
import json
import multiprocessing
import os

import numpy as np

from mfi_drake.config import scenario as sc
from mfi_drake.files import atomic_path
from mfi_drake.world.mesh_files import read_mesh
from mfi_drake.world.meshes import enclosed_volume
from mfi_drake.world.surfaces import THICKNESS, surface_slabs, welded

# CoACD's parameters: its concavity threshold (0.05) with a fixed seed, so
# that a mesh decomposes the same on every machine, and its search bounded so
# that one mesh of a world costs a second or two, not minutes (its defaults
# took 35 s for one 6,000-triangle cabinet of the PyBullet kitchen, and 13 s
# for five of its meshes that these take 7 s for): at most 12 pieces, a
# shallower and smaller tree search, fewer samples (the pieces of a world
# are all registered in the flight's SceneGraph, whose cost grows as their
# number squared: docs/big_scenes.md).
COACD = {
    "threshold": 0.05,
    "seed": 0,
    "max_convex_hull": 12,
    "resolution": 500,
    "mcts_nodes": 10,
    "mcts_iterations": 15,
    "mcts_max_depth": 2,
}
# An open mesh whose slabs would be more than this (a finely tessellated
# curved surface: thousands of slabs) flies as MAX_SLABS pieces instead,
# each the hull of a group of neighbouring triangles (`_grouped_pieces`).
MAX_SLABS = 16
# A closed mesh enclosing at least this share of its hull's volume flies as
# its hull, one piece, without CoACD (a box, a cylinder, a tessellated ball).
NEAR_CONVEX = 0.95
CACHE_VERSION = 2  # bumped when what is cached changes


def cache_dir() -> str:
    """Where pieces are cached: $MFI_DRAKE_CACHE, else the user's cache
    directory ($XDG_CACHE_HOME or ~/.cache) /mfi_drake/pieces."""
    if os.environ.get("MFI_DRAKE_CACHE"):
        return os.environ["MFI_DRAKE_CACHE"]
    base = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache")
    return os.path.join(base, "mfi_drake", "pieces")


def _solid(points: np.ndarray) -> bool:
    centred = points - points.mean(axis=0)
    return len(points) >= 4 and np.linalg.matrix_rank(centred, tol=1e-9) == 3


def convex_pieces(vertices: np.ndarray, triangles: np.ndarray) -> list[np.ndarray]:
    """The vertices (K, 3) of each convex piece of the closed mesh, from the
    cache or from CoACD. Raises ValueError, one line, if the mesh has no
    faces, encloses no volume or no piece of it spans one."""
    vertices = np.ascontiguousarray(vertices, dtype=float)
    triangles = np.ascontiguousarray(triangles, dtype=np.int64)
    if not len(triangles):
        raise ValueError("has no faces to decompose")
    if abs(enclosed_volume(vertices, triangles)) <= 1e-9 * np.ptp(vertices) ** 3:
        raise ValueError("cannot be decomposed: it encloses no volume (flat or open)")
    return _cached(vertices, triangles, ["coacd", COACD], _coacd)


def _coacd(vertices: np.ndarray, triangles: np.ndarray) -> list[np.ndarray]:
    import coacd  # imported here: only a scenario with a mesh pays for it

    coacd.set_log_level("error")
    try:
        parts = coacd.run_coacd(coacd.Mesh(vertices, triangles), **COACD)
    except Exception as e:  # CoACD raises RuntimeError and others
        raise ValueError(f"cannot be decomposed ({e})") from None
    pieces = [np.asarray(v, float) for v, _ in parts if _solid(np.asarray(v))]
    if not pieces:
        raise ValueError("cannot be decomposed: no piece spans a volume")
    return pieces


def _cached(vertices, triangles, method: list, compute) -> list[np.ndarray]:
    """compute(vertices, triangles), read from the cache if a run with the
    same mesh and `method` (its name and parameters) wrote it there."""
    key = hashlib.sha256(vertices.tobytes() + triangles.tobytes())
    key.update(json.dumps([CACHE_VERSION, *method]).encode())
    path = os.path.join(cache_dir(), f"{key.hexdigest()}.npz")
    if os.path.isfile(path):
        with np.load(path) as cached:
            return [cached[f"piece_{k}"] for k in range(len(cached.files))]
    pieces = compute(vertices, triangles)
    with atomic_path(path) as tmp:
        np.savez(tmp, **{f"piece_{k}": p for k, p in enumerate(pieces)})
    return pieces


def _oriented(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray | None:
    """The triangles of a watertight mesh (each edge in two of them) wound
    consistently outwards; None for a mesh that is not watertight."""
    import trimesh  # imported here: only a scenario with a mesh pays for it

    mesh = trimesh.Trimesh(vertices, triangles, process=False)
    if not mesh.is_watertight:
        return None
    trimesh.repair.fix_winding(mesh)
    if mesh.volume < 0:
        mesh.invert()
    return np.asarray(mesh.faces, dtype=np.int64)


def mesh_pieces(vertices: np.ndarray, triangles: np.ndarray, scale) -> list:
    """The vertices (K, 3) of each convex piece of the mesh scaled by `scale`
    (a number or one per axis), its equal corners welded: the hull of a
    closed mesh that fills NEAR_CONVEX of it, CoACD's pieces of another
    closed mesh, else slabs over its surface (`surfaces`; over MAX_SLABS
    of them: CoACD's pieces of it remeshed closed). Raises ValueError,
    one line."""
    from scipy.spatial import ConvexHull, QhullError

    vertices = np.ascontiguousarray(vertices, dtype=float)
    triangles = np.ascontiguousarray(triangles, dtype=np.int64)
    scale = np.broadcast_to(np.asarray(scale, float), 3)
    if not len(triangles):
        raise ValueError("has no faces to decompose")
    vertices, triangles = welded(vertices, triangles)
    oriented = _oriented(vertices, triangles)
    volume = 0.0 if oriented is None else enclosed_volume(vertices, oriented)
    if volume > 1e-9 * np.ptp(vertices) ** 3:
        try:
            hull = ConvexHull(vertices)
        except QhullError:
            hull = None
        if hull is not None and volume >= NEAR_CONVEX * hull.volume:
            return [vertices[hull.vertices] * scale]
        return [piece * scale for piece in convex_pieces(vertices, oriented)]
    scaled = np.ascontiguousarray(vertices * scale)
    method = ["surface", THICKNESS, MAX_SLABS]
    return _cached(scaled, triangles, method, _surface_pieces)


def _surface_pieces(vertices: np.ndarray, triangles: np.ndarray) -> list:
    """Slabs over an open mesh's surface, or, over MAX_SLABS of them,
    `_grouped_pieces`."""
    slabs = surface_slabs(vertices, triangles, limit=MAX_SLABS)
    if len(slabs) <= MAX_SLABS:
        return slabs
    return _grouped_pieces(vertices, triangles, MAX_SLABS)


def _grouped_pieces(
    vertices: np.ndarray, triangles: np.ndarray, count: int
) -> list[np.ndarray]:
    """`count` convex pieces holding an open mesh's surface: its triangles
    halved along the longest extent of their centres, again and again (a
    bounding-volume tree's leaves), each group's hull thickened by
    THICKNESS along its thinnest axis. Each piece holds its triangles, so
    the surface is inside the pieces; a piece overreaches the surface by
    the group's curvature over its width (with MAX_SLABS groups, a few
    centimetres for a kitchen's bowls and shades)."""
    centres = vertices[triangles].mean(axis=1)
    groups, pieces = [(np.arange(len(triangles)), count)], []
    while groups:
        members, share = groups.pop()
        if share > 1 and len(members) > 1:
            ends = centres[members]
            order = members[np.argsort(ends[:, np.argmax(np.ptp(ends, axis=0))])]
            cut = min(max(len(order) * (share // 2) // share, 1), len(order) - 1)
            groups += [(order[:cut], share // 2), (order[cut:], share - share // 2)]
            continue
        points = vertices[np.unique(triangles[members])]
        _, _, axes = np.linalg.svd(points - points.mean(axis=0))
        offset = 0.5 * THICKNESS * axes[-1]
        piece = np.vstack([points + offset, points - offset])
        if _solid(piece):  # not a group of triangles of no area
            pieces.append(piece)
    return pieces


def mesh_obstacles(
    obstacle: sc.Obstacle, path: str, scale, name: str, known: dict | None = None
) -> list[sc.Obstacle]:
    """An obstacle whose shape is the mesh file `path` (any format of
    `mesh_files.MESH_SUFFIXES`, scaled by `scale`, a number or one per axis:
    SDFormat's <scale>) as its convex pieces (`mesh_pieces`, or `known`'s:
    `prefetch_pieces`'), as `placed_pieces` places them. Raises
    ValueError, one line."""
    pieces = (known or {}).get(mesh_key(path, scale))
    if pieces is None:
        pieces = mesh_pieces(*read_mesh(path), scale)
    return placed_pieces(obstacle, pieces, name)


def placed_pieces(
    obstacle: sc.Obstacle, pieces: list[np.ndarray], name: str
) -> list[sc.Obstacle]:
    """Convex pieces (each (n, 3) vertices in `obstacle`'s frame) as
    obstacles at its pose and with its motion, named "`name` piece k". A
    piece of an obstacle that does not move is centred on its own origin,
    so that its bounding radius is its own size, not its distance from the
    obstacle's origin (which made every piece of a room a candidate nearest
    any point: `obstacles._candidates`)."""
    # Imported here: a decomposing worker process needs no pydrake.
    from mfi_drake.config.dynamic import moves
    from mfi_drake.world.motion import obstacle_pose

    X = obstacle_pose(obstacle)
    still = not moves(obstacle.motion)
    out = []
    for k, piece in enumerate(pieces):
        centre = (piece.min(axis=0) + piece.max(axis=0)) / 2 if still else np.zeros(3)
        out.append(
            dataclasses.replace(
                obstacle,
                shape=sc.Convex(vertices=(piece - centre).tolist()),
                position=[float(x) for x in X.multiply(centre)],
                name=f"{name} piece {k}",
            )
        )
    return out


def mesh_key(path: str, scale) -> tuple[str, tuple]:
    """A mesh file and its scale as `prefetch_pieces` keys them."""
    return path, tuple(np.ravel(scale).astype(float).tolist())


def _warm(path: str, scale) -> list[np.ndarray] | None:
    """The pieces of the mesh file `path`, into the cache too; None for a
    mesh that cannot be read or decomposed (`mesh_obstacles` refuses it)."""
    with contextlib.suppress(ValueError):
        return mesh_pieces(*read_mesh(path), scale)
    return None


def hull_pieces(meshes: list[tuple[str, object]]) -> dict:
    """The convex hull of each mesh file of `meshes` ((path, scale) pairs)
    as its one piece, by `mesh_key`: what MuJoCo collides with. None for a
    mesh that cannot be read (`mesh_obstacles` names why) or has no hull
    (flat: decomposed into slabs instead)."""
    from scipy.spatial import ConvexHull, QhullError

    pieces = {}
    for key in dict.fromkeys(mesh_key(p, s) for p, s in meshes):
        with contextlib.suppress(ValueError, QhullError):
            vertices = read_mesh(key[0])[0] * np.asarray(key[1])
            pieces[key] = [vertices[ConvexHull(vertices).vertices]]
    return pieces


def prefetch_pieces(meshes: list[tuple[str, object]]) -> dict:
    """The pieces of the mesh files of `meshes` ((path, scale) pairs), by
    `mesh_key`, decomposed at once, a process a core, and cached; none
    for one mesh or one core (nothing to share: `mesh_obstacles`
    decomposes it), nor for a mesh that cannot be decomposed."""
    unique = list(dict.fromkeys(mesh_key(p, s) for p, s in meshes))
    # The largest files first, so that no core is left with one at the end.
    unique.sort(key=lambda m: -os.path.getsize(m[0]) if os.path.isfile(m[0]) else 0)
    workers = min(len(unique), os.cpu_count() or 1)
    if workers < 2:
        return {}
    # Spawned, not forked: the parent may hold threads (numba, Drake).
    spawn = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(workers, mp_context=spawn) as pool:
        found = pool.map(_warm, *zip(*unique, strict=True))
        return {k: v for k, v in zip(unique, found, strict=True) if v is not None}


def with_meshes(scenario: sc.Scenario, where: str) -> sc.Scenario:
    """`scenario` with each `!Mesh` obstacle replaced by its convex pieces,
    in place; itself without one. Raises ScenarioError naming `where`, the
    obstacle and the file."""
    if not any(isinstance(o.shape, sc.Mesh) for o in scenario.obstacles):
        return scenario
    known = prefetch_pieces(
        [
            (os.path.join(scenario.base_dir, o.shape.file), o.shape.scale)
            for o in scenario.obstacles
            if isinstance(o.shape, sc.Mesh)
        ]
    )
    obstacles = []
    for i, obstacle in enumerate(scenario.obstacles):
        shape = obstacle.shape
        if not isinstance(shape, sc.Mesh):
            obstacles.append(obstacle)
            continue
        name = obstacle.name or f"obstacles[{i}] (mesh {shape.file!r})"
        path = os.path.join(scenario.base_dir, shape.file)
        try:
            obstacles += mesh_obstacles(obstacle, path, shape.scale, name, known)
        except ValueError as e:
            sc.fail(f"{where}: obstacles[{i}]", "shape.file", shape.file, str(e))
    return dataclasses.replace(scenario, obstacles=obstacles)
