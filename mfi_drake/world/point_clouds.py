"""Point-cloud maps as a scenario's `world:`: a recorded cloud (PLY, PCD, an
aerial survey's LAS or LAZ, or text: XYZ, PTS) read with a maintained
reader (plyfile, pypcd4, laspy with lazrs; numpy for text), checked, and
thinned to `Scenario.map_voxel` (`maths.point_maps.downsample`). Loading puts the
thinned points inline in `Scenario.map_points` and empties `world`, so the
scenario that travels (as YAML, to a sweep's workers) carries the points,
not the path.

A cloud as sensors record it is often organized (one point a pixel, an
image's rows and columns) with NaN (or inf) where a pixel had no return:
those points are no surface, and are dropped with one warning line that
counts them."""

import dataclasses
import os
import warnings

import numpy as np

from mfi_drake.config import scenario as sc
from mfi_drake.config.worlds import ScenarioWarning
from mfi_drake.maths.point_maps import downsample
from mfi_drake.world.mesh_files import bounded_memory, read_failure
from mfi_drake.world.obstacles import obstacle_triangles


def read_cloud(path: str) -> tuple[np.ndarray, int]:
    """((n, 3) float64: the x, y, z of every finite point of the PLY, PCD,
    LAS, LAZ, XYZ or PTS file `path` (LAS: its scaled coordinates, in the
    file's units), how many points were not finite and are left out). Raises
    ValueError, one line, for a file that is missing, unreadable, without
    x, y, z, or without a finite point."""
    if not os.path.isfile(path):
        raise ValueError(f"no such file ({path})")
    try:
        suffix = os.path.splitext(path)[1].lower()
        with bounded_memory(path):
            if suffix == ".ply":
                from plyfile import PlyData  # imported here: only a map pays

                vertex = PlyData.read(path)["vertex"]
                points = np.column_stack([vertex[k] for k in "xyz"])
            elif suffix in (".las", ".laz"):
                import laspy

                survey = laspy.read(path)
                points = np.column_stack([survey.x, survey.y, survey.z])
            elif suffix in (".xyz", ".pts"):
                points = _text_cloud(path)
            else:
                from pypcd4 import PointCloud

                points = PointCloud.from_path(path).numpy(("x", "y", "z"))
    except Exception as e:  # the readers raise many kinds; the user needs one line
        raise ValueError(f"not readable as a point cloud: {read_failure(e)}") from None
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(points) == 0:
        raise ValueError("holds no points")
    finite = np.isfinite(points).all(axis=1)
    if not finite.any():
        raise ValueError(f"holds no finite point (all {len(points)} are NaN or inf)")
    return points[finite], int(len(points) - finite.sum())


def _text_cloud(path: str) -> np.ndarray:
    """A text cloud as scanners and CloudCompare export it: a point a line,
    x y z first (then intensity, colour... not read), separated by spaces
    or commas; lines of "#" or "//" are comments; a .pts file's first line,
    the count of its points, is no point."""
    comment = ("#", "//")
    head = []  # (line number, text) of the first lines that are no comment
    with open(path, encoding="utf-8", errors="replace") as f:
        for n, line in enumerate(f):
            if line.strip() and not line.strip().startswith(comment):
                head.append((n, line.strip()))
                if len(head) == 2:  # the count line, if any, and a point
                    break
    counted = bool(head) and head[0][1].isdigit()  # a .pts count line
    if len(head) <= counted:  # no point (numpy would warn on stderr)
        return np.empty((0, 3))
    return np.loadtxt(
        path,
        usecols=(0, 1, 2),
        comments=comment,
        delimiter="," if "," in head[int(counted)][1] else None,
        skiprows=head[0][0] + 1 if counted else 0,
        ndmin=2,
    )


def with_map(scenario: sc.Scenario, where: str) -> sc.Scenario:
    """`scenario` with its map file's points thinned into `map_points` and
    `world` emptied; raises ScenarioError naming `where`, the field and the
    file."""
    path = os.path.join(scenario.base_dir, scenario.world)
    try:
        points, dropped = read_cloud(path)
    except ValueError as e:
        sc.fail(where, "world", scenario.world, str(e))
    if dropped:
        warnings.warn(
            f"{where}: world = {scenario.world!r}: {dropped} of "
            f"{dropped + len(points)} points are not finite (no return) and "
            "are left out",
            ScenarioWarning,
            stacklevel=2,
        )
    thinned = downsample(points, scenario.map_voxel)
    return dataclasses.replace(scenario, map_points=thinned.tolist(), world="")


def surface_samples(scenario: sc.Scenario, count: int, seed: int = 0) -> np.ndarray:
    """(count, 3): points drawn uniformly (by area) on the surfaces of the
    scenario's obstacles at t = 0, the same for the same `seed`: a
    point-cloud map of a known world, as a scanner would record it."""
    triangles = np.concatenate(
        [obstacle_triangles(scenario, o) for o in scenario.obstacles]
    )
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(triangles), size=count, p=area / area.sum())
    u, v = rng.random((2, count))
    flip = u + v > 1.0  # folded back into the triangle: uniform on it
    u[flip], v[flip] = 1.0 - u[flip], 1.0 - v[flip]
    return a[pick] + u[:, None] * (b - a)[pick] + v[:, None] * (c - a)[pick]


def write_ply(path: str, points: np.ndarray) -> None:
    """`points` (n, 3) as a binary PLY file of float32 x, y, z (what a
    scanner's software writes)."""
    from plyfile import PlyData, PlyElement

    vertex = np.empty(len(points), dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")])
    for k, axis in enumerate("xyz"):
        vertex[axis] = points[:, k]
    PlyData([PlyElement.describe(vertex, "vertex")]).write(path)
