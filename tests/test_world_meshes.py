"""Meshes in the formats people have (STL binary and ASCII, PLY, COLLADA in
centimetres and Y-up, glTF and GLB), open meshes flown as slabs over their
surfaces, and organized clouds with holes (tests/data/meshes, written by
its make_fixtures.py). The oracles: each box file against the same box as
a `!Box` (closest points, SceneGraph both ways); the glTF axes against
Drake's own glTF reader; the open wall's sensor readings against a
brute-force point-to-triangle distance in numpy; the cloud's hole count by
hand from how the fixture was made."""

import logging
import os
import warnings

import numpy as np
import pytest
from pydrake.geometry import Convex as DrakeConvex
from pydrake.geometry import SceneGraph

from mfi_drake.config import scenario as sc
from mfi_drake.maths.layout import seen_points
from mfi_drake.world.decomposition import mesh_obstacles
from mfi_drake.world.mesh_files import read_mesh
from mfi_drake.world.obstacles import (
    nearest_obstacles,
    obstacle_distances,
    register_obstacles,
)
from mfi_drake.world.surfaces import THICKNESS
from mfi_drake.world.validation import ScenarioWarning, load_scenario

from .conftest import ROOT

DATA = os.path.join(ROOT, "tests", "data", "meshes")
BOXES = [
    "box_binary.stl",
    "box_ascii.stl",
    "box.ply",
    "box_cm.dae",
    "box_y_up.dae",
    "box_textured.dae",  # its image is cut off halfway: read without it
    "box_imageless.dae",  # its image names no file: pycollada dropped the box
    "box.gltf",
    "box.glb",
]
SIZE = np.array([1.0, 2.0, 0.5])  # the fixtures' box, corner at the origin
POSE = {"position": [3.0, -1.0, 2.0], "rpy_deg": [10.0, -20.0, 35.0]}


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("MFI_DRAKE_CACHE", str(tmp_path / "pieces"))


def _probe_points(seed: int, centre, spread: float, count: int = 60) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.asarray(centre) + rng.uniform(-spread, spread, (count, 3))


def _box_obstacle(scale=(1.0, 1.0, 1.0)) -> sc.Obstacle:
    """The fixtures' box (scaled) as a `!Box` at POSE: its centre is the
    mesh frame's point scale ⊙ SIZE / 2."""
    mesh_frame = sc.Obstacle(**POSE)
    from mfi_drake.world.motion import obstacle_pose

    centre = obstacle_pose(mesh_frame).multiply(np.asarray(scale) * SIZE / 2)
    return sc.Obstacle(
        shape=sc.Box(size=(np.asarray(scale) * SIZE).tolist()),
        position=centre.tolist(),
        rpy_deg=POSE["rpy_deg"],
    )


@pytest.mark.parametrize("name", BOXES)
def test_each_box_file_is_the_box(name):
    """Read: the eight corners of the box, in metres, z-up, whatever the
    file's unit and up axis."""
    vertices, triangles = read_mesh(os.path.join(DATA, name))
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])
    expected = corners * SIZE
    got = np.unique(np.round(vertices, 9), axis=0)
    np.testing.assert_allclose(got, expected[np.lexsort(expected.T[::-1])], atol=1e-6)
    assert len(triangles) == 12


def test_a_textured_mesh_reads_without_a_word(caplog):
    """Its textures are not read, and trimesh's complaint of each one ("unable
    to load bumpmap" and a traceback, on stderr) is not said."""
    with caplog.at_level(logging.DEBUG):
        vertices, _ = read_mesh(os.path.join(DATA, "box_textured.dae"))
    assert len(np.unique(np.round(vertices, 9), axis=0)) == 8
    said = [r for r in caplog.records if r.name.startswith("trimesh")]
    assert not [r for r in said if r.levelno >= logging.WARNING], said


@pytest.mark.parametrize("name", BOXES)
def test_each_box_file_flies_as_the_box(name):
    """As obstacles, at a pose and with SDFormat's per-axis <scale>: the
    distances from points around it are the `!Box`'s, within 1 mm (CoACD's
    pieces of a box are its hull)."""
    scale = [1.5, 1.0, 0.5]
    pieces = mesh_obstacles(sc.Obstacle(**POSE), os.path.join(DATA, name), scale, "b")
    box = _box_obstacle(scale)
    points = _probe_points(1, box.position, 2.5)
    got = obstacle_distances(sc.Scenario(obstacles=pieces), points)
    expected = obstacle_distances(sc.Scenario(obstacles=[box]), points)
    np.testing.assert_allclose(got, expected, atol=1e-3)


def test_meshes_are_decomposed_in_parallel_into_the_cache(monkeypatch):
    """`prefetch_pieces` decomposes an open mesh (slabs) in worker
    processes: this process then reads it from the cache; the box, convex,
    is its hull, cached nowhere and never given to CoACD (made to fail
    here), the box scaled."""
    import coacd

    from mfi_drake.world import decomposition

    box, wall = os.path.join(DATA, "box_cm.dae"), os.path.join(DATA, "wall_open.ply")
    decomposition.prefetch_pieces([(box, 2.0), (wall, 1.0)])
    assert len(os.listdir(decomposition.cache_dir())) == 1  # the wall's slabs

    def fail(*args, **kwargs):
        raise AssertionError("decomposed again")

    monkeypatch.setattr(coacd, "run_coacd", fail)
    pieces = mesh_obstacles(sc.Obstacle(), box, 2.0, "box")
    hull = np.concatenate([p.shape.vertices for p in pieces])
    np.testing.assert_allclose(np.ptp(hull, axis=0), SIZE * 2.0, atol=1e-3)
    assert len(mesh_obstacles(sc.Obstacle(), wall, 1.0, "wall")) == 16


def test_gltf_axes_are_drakes():
    """The glTF's y-up axes turned z-up as Drake's own glTF reader turns
    them: the same hull."""
    path = os.path.join(DATA, "box.gltf")
    hull = DrakeConvex(path).GetConvexHull()
    drake = np.array([hull.vertex(i) for i in range(hull.num_vertices())])
    mine, _ = read_mesh(path)
    np.testing.assert_allclose(drake.min(axis=0), mine.min(axis=0), atol=1e-9)
    np.testing.assert_allclose(drake.max(axis=0), mine.max(axis=0), atol=1e-9)


def _point_triangle_distances(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(p,) the distance from each point to the nearest of the triangles
    (t, 3, 3), brute force: the distance to the plane where the foot of
    the perpendicular is inside the triangle, else to the nearest edge."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1)[:, None]
    out = np.full(len(points), np.inf)
    for k, p in enumerate(points):
        height = np.einsum("ij,ij->i", p - a, n)
        foot = p - height[:, None] * n
        inside = np.ones(len(a), dtype=bool)
        for u, v in ((a, b), (b, c), (c, a)):
            inside &= np.einsum("ij,ij->i", np.cross(v - u, foot - u), n) >= 0
        best = np.where(inside, np.abs(height), np.inf)
        for u, v in ((a, b), (b, c), (c, a)):
            edge = v - u
            t = np.clip(np.einsum("ij,ij->i", p - u, edge) / (edge * edge).sum(1), 0, 1)
            best = np.minimum(best, np.linalg.norm(p - (u + t[:, None] * edge), axis=1))
        out[k] = best.min()
    return out


def test_an_open_wall_flies_as_its_surface():
    """The open wall (two single-sided walls, one with a door) is no volume:
    it flies as slabs, few of them, and the sphere sensor's closest points
    are on the wall: each reading's distance is the brute-force distance
    to the triangles within THICKNESS, and each closest point lies within
    THICKNESS of a triangle. The door stays open: its middle is 0.5 m
    from the wall's edges."""
    path = os.path.join(DATA, "wall_open.ply")
    vertices, triangles = read_mesh(path)
    pieces = mesh_obstacles(sc.Obstacle(), path, 1.0, "wall")
    assert len(pieces) <= 20 < len(triangles)  # 16 slabs for 152 triangles
    scenario = sc.Scenario(obstacles=pieces)
    scene_graph = SceneGraph()
    register_obstacles(scene_graph, scenario)
    query = scene_graph.get_query_output_port().Eval(scene_graph.CreateDefaultContext())
    surface = vertices[triangles]
    points = _probe_points(2, [2.0, 1.0, 1.5], 2.5, count=80)
    points = points[_point_triangle_distances(points, surface) > THICKNESS]
    truth = _point_triangle_distances(points, surface)
    for p, d in zip(points, truth, strict=True):
        reading = seen_points(nearest_obstacles(query, p, 10.0))
        offsets = np.asarray(reading)  # r_o: closest point minus p
        assert abs(np.linalg.norm(offsets[0]) - d) <= THICKNESS
        on_wall = _point_triangle_distances(p + offsets, surface)
        assert on_wall.max() <= THICKNESS
    door = np.array([[2.0, 0.0, 1.0]])
    np.testing.assert_allclose(
        obstacle_distances(scenario, door), [0.5], atol=THICKNESS
    )


def test_an_open_mesh_scenario_loads(tmp_path):
    """`!Mesh` of the open wall in a scenario: loaded (no refusal), and the
    start 1 m in front of the wall is 1 m from it (within the slab)."""
    path = tmp_path / "wall.yaml"
    wall = os.path.join(DATA, "wall_open.ply")
    path.write_text(
        "start: [3.0, -1.0, 1.5]\ngoal: [3.0, -3.0, 1.5]\nduration: 5.0\n"
        f"obstacles:\n  - shape: !Mesh {{file: {wall}}}\n"
    )
    scenario = load_scenario(str(path))
    assert all(isinstance(o.shape, sc.Convex) for o in scenario.obstacles)
    (d,) = obstacle_distances(scenario, [[3.0, -1.0, 1.5]])
    assert abs(d - 1.0) <= THICKNESS


def test_an_organized_cloud_drops_its_holes_in_one_line(tmp_path):
    """organized.pcd (binary_compressed, 32 × 24): NaN in every third column
    from column 4 (10 columns × 24 rows) and in the bottom two rows (2 × 22
    more): 284 of 768 points dropped, one warning line; the wall it holds
    (x = 3, 0.1 m apart) is where a !Box of it is, within the points'
    spacing and the thinning voxel."""
    path = tmp_path / "cloud.yaml"
    path.write_text(
        "start: [0.0, 0.0, 1.5]\ngoal: [1.0, 0.0, 1.5]\nduration: 5.0\n"
        f"world: {os.path.join(DATA, 'organized.pcd')}\n"
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scenario = load_scenario(str(path))
    (warning,) = [w for w in caught if issubclass(w.category, ScenarioWarning)]
    assert "284 of 768 points are not finite (no return)" in str(warning.message)
    assert "\n" not in str(warning.message)
    kept = np.asarray(scenario.map_points)
    assert np.isfinite(kept).all() and np.allclose(kept[:, 0], 3.0)
    # Rows 0..21 (z from 2.5 down to 0.4), columns 0..31 (y from −1.5 to 1.6).
    wall = sc.Obstacle(shape=sc.Box(size=[1e-3, 3.1, 2.1]), position=[3.0, 0.05, 1.45])
    points = np.array([[1.0, y, z] for y in (-1.0, 0.0, 1.0) for z in (1.0, 2.0)])
    got = obstacle_distances(scenario, points)
    expected = obstacle_distances(sc.Scenario(obstacles=[wall]), points)
    spacing = 0.15 * np.sqrt(2) / 2 + scenario.map_voxel * np.sqrt(3)
    np.testing.assert_allclose(got, np.asarray(expected) - 5e-4, atol=spacing)


def test_a_vertex_too_far_out_fails_in_one_line(tmp_path):
    """A finite vertex whose products overflow floats (1e308 m, found by
    the loader fuzz: it made NaN surfaces) is refused by name, before any
    surface is built; 1e6 m still reads."""
    for far, ok in ((1e308, False), (1e6, True)):
        path = tmp_path / f"far_{far:g}.obj"
        path.write_text(f"v 0 0 0\nv 1 0 0\nv 0 1 {far}\nf 1 2 3\n")
        if ok:
            vertices, _ = read_mesh(str(path))
            assert vertices[:, 2].max() == far
        else:
            with pytest.raises(ValueError, match="1e\\+308 m out, beyond 1e\\+07 m"):
                read_mesh(str(path))
