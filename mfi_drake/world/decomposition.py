"""Meshes of any shape: a non-convex mesh (`!Mesh`, or a mesh geometry of a
`world:` file) flies as the convex pieces CoACD decomposes it into, each an
inline `!Convex` at the mesh's pose (docs/usage.md, "Meshes of any shape",
has the comparison with V-HACD that chose CoACD).

Decomposing costs seconds; the pieces are cached on disk under the user's
cache directory, keyed by the mesh's vertices and triangles and by the
decomposition's parameters, so a second flight does not pay again.
"""

import dataclasses
import hashlib
import json
import os

import numpy as np

from mfi_drake.config import scenario as sc
from mfi_drake.files import atomic_path
from mfi_drake.world.meshes import enclosed_volume, read_obj

# CoACD's parameters: its defaults (concavity threshold 0.05) with a fixed
# seed, so that a mesh decomposes the same on every machine.
COACD = {"threshold": 0.05, "seed": 0}
CACHE_VERSION = 1  # bumped when what is cached changes


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
    key = hashlib.sha256(vertices.tobytes() + triangles.tobytes())
    key.update(json.dumps([CACHE_VERSION, "coacd", COACD]).encode())
    path = os.path.join(cache_dir(), f"{key.hexdigest()}.npz")
    if os.path.isfile(path):
        with np.load(path) as cached:
            return [cached[f"piece_{k}"] for k in range(len(cached.files))]
    import coacd  # imported here: only a scenario with a mesh pays for it

    coacd.set_log_level("error")
    try:
        parts = coacd.run_coacd(coacd.Mesh(vertices, triangles), **COACD)
    except Exception as e:  # CoACD raises RuntimeError and others
        raise ValueError(f"cannot be decomposed ({e})") from None
    pieces = [np.asarray(v, float) for v, _ in parts if _solid(np.asarray(v))]
    if not pieces:
        raise ValueError("cannot be decomposed: no piece spans a volume")
    with atomic_path(path) as tmp:
        np.savez(tmp, **{f"piece_{k}": p for k, p in enumerate(pieces)})
    return pieces


def mesh_obstacles(
    obstacle: sc.Obstacle, path: str, scale, name: str
) -> list[sc.Obstacle]:
    """An obstacle whose shape is the OBJ mesh `path` (scaled by `scale`, a
    number or one per axis) as its convex pieces, each at its pose and with
    its motion, named "`name` piece k". Raises ValueError, one line."""
    if not os.path.isfile(path):
        raise ValueError(f"no such file ({path})")
    if not path.lower().endswith(".obj"):
        raise ValueError("a mesh to decompose must be a Wavefront OBJ file")
    pieces = convex_pieces(*read_obj(path))
    scale = np.broadcast_to(np.asarray(scale, float), 3)
    return [
        dataclasses.replace(
            obstacle,
            shape=sc.Convex(vertices=(piece * scale).tolist()),
            name=f"{name} piece {k}",
        )
        for k, piece in enumerate(pieces)
    ]


def with_meshes(scenario: sc.Scenario, where: str) -> sc.Scenario:
    """`scenario` with each `!Mesh` obstacle replaced by its convex pieces,
    in place; itself without one. Raises ScenarioError naming `where`, the
    obstacle and the file."""
    if not any(isinstance(o.shape, sc.Mesh) for o in scenario.obstacles):
        return scenario
    obstacles = []
    for i, obstacle in enumerate(scenario.obstacles):
        shape = obstacle.shape
        if not isinstance(shape, sc.Mesh):
            obstacles.append(obstacle)
            continue
        name = obstacle.name or f"obstacles[{i}] (mesh {shape.file!r})"
        path = os.path.join(scenario.base_dir, shape.file)
        try:
            obstacles += mesh_obstacles(obstacle, path, shape.scale, name)
        except ValueError as e:
            sc.fail(f"{where}: obstacles[{i}]", "shape.file", shape.file, str(e))
    return dataclasses.replace(scenario, obstacles=obstacles)
