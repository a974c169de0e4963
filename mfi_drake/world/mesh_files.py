"""Triangle meshes from the files people have: Wavefront OBJ, STL (binary
and ASCII), PLY, COLLADA (.dae) and glTF (.gltf, .glb), read with trimesh
(pycollada for COLLADA; docs/usage.md, "Meshes of any shape", has the
comparison that chose it) into metres in Drake's z-up frame:

- COLLADA: its <unit meter="…"> scales the vertices to metres, and its
  <up_axis> (Y_UP by the COLLADA spec when absent) turns them z-up, as
  Gazebo reads a .dae;
- glTF is y-up by its spec: turned z-up as Drake's own glTF reader does
  (+90° about x: the file's (x, y, z) is Drake's (x, −z, y));
- OBJ, STL and PLY carry no unit or axis: metres, z-up, as in Drake.

A file's node transforms (COLLADA, glTF scenes) are applied. Every failure
is a ValueError of one line.
"""

import contextlib
import io
import logging
import os
import re
import warnings
from collections.abc import Iterator

import numpy as np

MESH_SUFFIXES = (".obj", ".stl", ".ply", ".dae", ".gltf", ".glb")
FARTHEST = 1e7  # m, the farthest a mesh's vertex may lie from its origin
# Each up axis's rotation to z-up (rows: Drake's x, y, z from the file's).
_TO_Z_UP = {
    "X_UP": np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
    "Y_UP": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
    "Z_UP": np.eye(3),
}
# How much of a COLLADA file is searched for its <asset>: it comes first.
_ASSET_BYTES = 1 << 16
# The memory a reader may take beyond the process's own: this much, and
# this many bytes for each byte of the file. A header that declares more
# than its file holds (a mutated count, a 4 GB chunk length) then fails as
# a MemoryError, one line, instead of taking the machine's memory: the
# loaders' fuzz found a GLB whose reading grew past 20 GB.
READ_MEMORY_BASE = 1 << 30
READ_BYTES_PER_FILE_BYTE = 256


@contextlib.contextmanager
def quiet_readers() -> Iterator[None]:
    """trimesh's warnings while it reads (a texture it was not given, "unable
    to load bumpmap" and a traceback on stderr) left unsaid: a reader's
    failure reaches the user as `read_mesh`'s one line."""
    logger = logging.getLogger("trimesh")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


@contextlib.contextmanager
def bounded_memory(path: str) -> Iterator[None]:
    """Caps the process's address space, while a reader reads `path`, at
    its present size plus what READ_MEMORY_BASE and READ_BYTES_PER_FILE_BYTE
    allow (a lower limit already set stays). Where the process's size or
    its limit cannot be read (not Linux), the reader runs unbounded."""
    try:
        import resource

        soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        with open("/proc/self/statm") as f:
            used = int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (ImportError, OSError, ValueError):
        yield
        return
    limit = used + READ_MEMORY_BASE + READ_BYTES_PER_FILE_BYTE * os.path.getsize(path)
    for bound in (soft, hard):
        if bound != resource.RLIM_INFINITY:
            limit = min(limit, bound)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def read_failure(e: Exception) -> str:
    """The one line that says why a reader failed (readers raise many kinds)."""
    if isinstance(e, MemoryError):
        return "declares more data than the file holds (reading it ran out of memory)"
    return str(e).splitlines()[0][:200] if str(e) else type(e).__name__


def read_mesh(path: str) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (N, 3) in metres, z-up; triangles (M, 3) of indices) of the
    mesh file `path`, of any of MESH_SUFFIXES. Raises ValueError, one line,
    for a file missing, of another kind, unreadable or without triangles."""
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in MESH_SUFFIXES:
        raise ValueError(
            f"a mesh must be one of {', '.join(MESH_SUFFIXES)} (not {suffix or path!r})"
        )
    if not os.path.isfile(path):
        raise ValueError(f"no such file ({path})")
    vertices, triangles = _trimesh(path, suffix)
    if suffix == ".dae":
        meter, up = collada_asset(path)
        vertices = vertices @ _TO_Z_UP[up].T * meter
    elif suffix in (".gltf", ".glb"):
        vertices = vertices @ _TO_Z_UP["Y_UP"].T
    if not len(triangles):
        raise ValueError("has no triangles")
    if not np.isfinite(vertices).all():
        raise ValueError("has a vertex that is not finite")
    farthest = float(np.abs(vertices).max(initial=0.0))
    if farthest > FARTHEST:
        # Finite but past where a triangle's cross product stays finite in
        # floats (a fuzzed STL at 1e308 m made NaN surfaces).
        raise ValueError(f"has a vertex {farthest:g} m out, beyond {FARTHEST:g} m")
    if triangles.min() < 0 or triangles.max() >= len(vertices):
        raise ValueError("has a face whose vertex does not exist")
    return vertices, triangles


def _trimesh(path: str, suffix: str) -> tuple[np.ndarray, np.ndarray]:
    """The file's triangles as one mesh, its scene's transforms applied and
    its equal vertices merged (STL repeats each triangle's corners)."""
    import trimesh  # imported here: only a scenario with a mesh pays for it

    try:
        # trimesh's merge of equal vertices casts absurd coordinates (1e308)
        # with a RuntimeWarning; the checks after reading judge the values.
        with warnings.catch_warnings(), quiet_readers(), bounded_memory(path):
            warnings.simplefilter("ignore", RuntimeWarning)
            # Materials and textures are not read: no flight sees them, and an
            # image cut off in a download would refuse the mesh.
            source = _unpainted(path) if suffix == ".dae" else path
            loaded = trimesh.load(
                source, file_type=suffix[1:], force="mesh", skip_materials=True
            )
        vertices = np.asarray(loaded.vertices, dtype=float)
        triangles = np.asarray(loaded.faces, dtype=np.int64).reshape(-1, 3)
    except Exception as e:  # the readers raise many kinds; the user needs one line
        raise ValueError(
            f"not readable as a {suffix[1:].upper()} mesh: {read_failure(e)}"
        ) from None
    return vertices.reshape(-1, 3), triangles


def _unpainted(path: str) -> io.BytesIO:
    """A COLLADA file without its images, effects and materials, nor their
    bindings to its geometry. Its reader has no switch to skip them, and
    where one is broken it drops the geometry bound to it: Gazebo's tray
    parts (an image whose file is commented out) read as no triangles."""
    with open(path, "rb") as f:
        data = f.read()
    data = re.sub(
        rb"<library_(images|effects|materials)\b(?:[^>]*/>|.*?</library_\1\s*>)",
        b"",
        data,
        flags=re.S,
    )
    return io.BytesIO(
        re.sub(rb"<bind_material\b.*?</bind_material\s*>", b"", data, flags=re.S)
    )


def collada_asset(path: str) -> tuple[float, str]:
    """(metres per unit, up axis) of a COLLADA file: its <asset>'s <unit
    meter> (1 if absent) and <up_axis> (Y_UP if absent, as the spec says).
    Raises ValueError for a unit that is not a positive number or an axis
    that is none of X_UP, Y_UP, Z_UP."""
    with open(path, "rb") as f:
        head = f.read(_ASSET_BYTES).decode("utf-8", "replace")
    asset = re.search(r"<asset\b.*?</asset>", head, re.S)
    text = asset.group(0) if asset else ""
    unit = re.search(r"<unit\b[^>]*\bmeter\s*=\s*[\"']([^\"']*)[\"']", text)
    up = re.search(r"<up_axis>\s*(\w+)\s*</up_axis>", text)
    axis = up.group(1) if up else "Y_UP"
    try:
        meter = float(unit.group(1)) if unit else 1.0
    except ValueError:
        meter = float("nan")
    if not (np.isfinite(meter) and meter > 0.0):
        raise ValueError(
            f"has a <unit meter> that is no positive number ({unit.group(1)!r})"
        )
    if axis not in _TO_Z_UP:
        raise ValueError(f"has an <up_axis> of {axis!r}, not X_UP, Y_UP or Z_UP")
    return meter, axis
