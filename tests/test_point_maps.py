"""Point-cloud maps (`world: map.ply` / `map.pcd`): read, thinned, sensed
through the depth camera's grouping, validated and flown. The oracles: a
map sampled densely from the planar wall flies as the wall does (clearance
to the true surfaces within the voxel); hand-computed thinning; readings
against brute force over the points; bad input is one line and exit 2."""

import dataclasses
import os
import time
import tracemalloc

import numpy as np
import pytest

from mfi_drake.app.cli import main
from mfi_drake.config import scenario as sc
from mfi_drake.config.scenario_yaml import scenario_from_yaml, scenario_to_yaml
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.config.worlds import ScenarioWarning
from mfi_drake.flight.result import outcome
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths.layout import seen_points
from mfi_drake.maths.point_maps import (
    MapReader,
    downsample,
    map_readings,
    nearest_points,
)
from mfi_drake.world.obstacles import obstacle_distances
from mfi_drake.world.point_clouds import surface_samples, write_ply
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

HEAD = """\
name: mapped
start: [0.0, 0.0, 1.5]
goal: [8.0, 0.0, 1.5]
duration: 40.0
"""


def _mapped(tmp_path, points=None, name="map.ply", extra="") -> str:
    """A scenario whose world is the map `name` holding `points` (the
    planar wall's surfaces sampled with 4000 points by default)."""
    if points is None:
        wall = load_scenario(os.path.join(SCENARIOS, "planar_wall.yaml"))
        points = surface_samples(wall, 4000)
    if name.endswith(".ply"):
        write_ply(str(tmp_path / name), points)
    path = tmp_path / "mapped.yaml"
    path.write_text(f"{HEAD}world: {name}\n{extra}")
    return str(path)


def test_downsample_is_each_voxels_centroid():
    """Hand-computed: three points in voxel (0, 0, 0) of edge 0.5, one in
    (1, 0, 0) and one in (-1, 0, 0)."""
    points = np.array(
        [
            [0.1, 0.1, 0.1],
            [0.2, 0.3, 0.4],
            [0.3, 0.2, 0.1],
            [0.7, 0.1, 0.1],
            [-0.2, 0.0, 0.0],
        ]
    )
    thinned = downsample(points, 0.5)
    expected = [[-0.2, 0.0, 0.0], [0.2, 0.2, 0.2], [0.7, 0.1, 0.1]]
    np.testing.assert_allclose(thinned, expected, atol=1e-15)


def test_nearest_points_is_brute_force():
    rng = np.random.default_rng(3)
    points, queries = rng.normal(size=(2000, 3)), rng.normal(size=(50, 3)) * 3
    d, index = nearest_points(points, queries)
    brute = np.linalg.norm(points[None] - queries[:, None], axis=2)
    np.testing.assert_array_equal(index, brute.argmin(axis=1))
    np.testing.assert_allclose(d, brute.min(axis=1), rtol=1e-15)


def test_map_readings_are_each_groups_nearest_point():
    """Two balls of points 2 m apart and one beyond r_s: two readings, each
    the nearest point of its ball (brute force), nearest first; the far
    ball unseen. A plane's points: one reading, its nearest point."""
    rng = np.random.default_rng(1)
    ball = rng.normal(size=(500, 3))
    ball = 0.5 * ball / np.linalg.norm(ball, axis=1, keepdims=True)
    centres = [[1.5, 0.0, 0.0], [0.0, -2.0, 0.0], [9.0, 0.0, 0.0]]
    balls = [ball + c for c in centres]
    p = np.zeros(3)
    seen = seen_points(map_readings(np.concatenate(balls).T, p, 3.0))
    brute = [b[np.argmin(np.linalg.norm(b, axis=1))] for b in balls[:2]]
    np.testing.assert_array_equal(seen, brute)
    grid = np.stack(np.meshgrid(np.arange(-3, 3, 0.05), np.arange(-3, 3, 0.05)), -1)
    plane = np.column_stack(
        [np.full(len(grid.reshape(-1, 2)), 1.0), grid.reshape(-1, 2)]
    )
    seen = seen_points(map_readings(plane.T, np.array([0.0, 0.02, 0.01]), 3.0))
    np.testing.assert_allclose(seen, [[1.0, -0.02, -0.01]], atol=1e-12)


def test_the_map_reader_reads_as_the_definition_bit_for_bit():
    """`MapReader` against `map_readings` over every point (the reading's
    definition, numpy): a room of boxes thinned as a map is, read along a
    wandering path of small steps (kept neighbourhoods) and jumps (new
    ones), from outside the map (nothing seen) and from inside boxes'
    clutter; equal to the last bit, every reading."""
    boxes = [
        sc.Obstacle(shape=sc.Box(size=[6.0, 0.1, 3.0]), position=[3.0, 0.0, 1.5]),
        sc.Obstacle(shape=sc.Box(size=[0.1, 5.0, 3.0]), position=[0.0, 2.5, 1.5]),
        sc.Obstacle(shape=sc.Box(size=[6.0, 5.0, 0.1]), position=[3.0, 2.5, 0.0]),
        sc.Obstacle(shape=sc.Box(size=[1.0, 0.6, 0.8]), position=[2.0, 2.0, 0.4]),
        sc.Obstacle(shape=sc.Sphere(radius=0.4), position=[4.0, 1.0, 1.2]),
        sc.Obstacle(
            shape=sc.Cylinder(radius=0.2, length=2.0), position=[1.0, 4.0, 1.0]
        ),
    ]
    points = downsample(surface_samples(sc.Scenario(obstacles=boxes), 60_000), 0.05)
    xyz = np.ascontiguousarray(points.T)
    reader = MapReader(points, 3.0)
    rng = np.random.default_rng(7)
    p, seen = np.array([2.0, 2.0, 1.5]), 0
    for k in range(300):
        if k % 50 == 0:  # a jump, once far outside the map
            p = rng.uniform([-1, -1, 0], [7, 6, 3]) if k != 100 else np.full(3, 50.0)
        p = p + rng.normal(0.0, 0.02, 3)
        got, expected = reader(p), map_readings(xyz, p, 3.0)
        np.testing.assert_array_equal(got, expected)
        seen += int(expected[3] > 0.5) + int(expected[7] > 0.5)
    assert seen > 300  # most readings see two or more obstacles


@pytest.mark.parametrize("dip", [0.0, 0.05, 0.3])
def test_the_compiled_basins_are_the_persistent_minima(dip):
    """`map_kernels.basins` (a flood from each candidate) against
    `perception.persistent_minima` (every component labelled) on the voxel
    graphs of random clouds, whose voxels' distances have many shallow
    minima: the same voxels, in the same order, for up to 12 of them."""
    from mfi_drake.maths import map_kernels
    from mfi_drake.maths.perception import persistent_minima, voxel_graph

    rng = np.random.default_rng(11)
    for trial in range(20):
        points = rng.uniform(0.0, 3.0, (rng.integers(5, 3000), 3))
        graph = voxel_graph(points)
        nearest = rng.uniform(0.0, 1.0, graph.count)
        nearest[rng.random(graph.count) < 0.1] = 0.5  # ties
        ends = np.concatenate([graph.a, graph.b])
        order = np.argsort(ends, kind="stable")
        indptr = np.searchsorted(ends[order], np.arange(graph.count + 1))
        others = np.concatenate([graph.b, graph.a])[order]
        count = int(rng.integers(1, 13))
        nodes = np.arange(graph.count)
        got = map_kernels.basins(nearest, (nodes, indptr, others, nodes), count, dip)
        expected = persistent_minima(nearest, graph.a, graph.b, count, dip)
        np.testing.assert_array_equal(got, expected, err_msg=f"trial {trial}")


def test_a_dense_map_of_the_wall_flies_as_the_wall(tmp_path):
    """The oracle: the planar wall's surfaces sampled with 200k points (a
    voxel of 0.05 m holds ~7 of them) fly with the geometric wall's outcome,
    and the map flight's clearance from the true wall (exact SceneGraph
    distances) is within the voxel of the geometric flight's."""
    wall = load_scenario(os.path.join(SCENARIOS, "planar_wall.yaml"))
    path = _mapped(tmp_path, surface_samples(wall, 200_000, seed=1))
    mapped = load_scenario(path)
    assert mapped.world == "" and mapped.map_voxel == 0.05
    geometric = simulate(wall)
    flown = simulate(mapped)
    true = obstacle_distances(wall, flown.positions)
    clearance = min(true) - VEHICLES[wall.vehicle].collision_radius
    print(
        f"wall: {outcome(geometric.metrics)}, clearance "
        f"{geometric.metrics['min_clearance']:.4f} m; map of "
        f"{len(mapped.map_points)} points: {outcome(flown.metrics)}, clearance "
        f"{clearance:.4f} m (to its points {flown.metrics['min_clearance']:.4f} m)"
    )
    assert outcome(flown.metrics) == outcome(geometric.metrics) == "success"
    assert abs(clearance - geometric.metrics["min_clearance"]) <= mapped.map_voxel


def test_the_shipped_map_flies_and_travels_as_its_points():
    """scenarios/planar_wall_map.yaml reaches its goal; its scenario as YAML
    (what a sweep's worker gets) holds the points, not the file, and flies
    the same flight bit for bit."""
    scenario = load_scenario(os.path.join(SCENARIOS, "planar_wall_map.yaml"))
    assert 3000 < len(scenario.map_points) <= 4000
    travelled = scenario_from_yaml(scenario_to_yaml(scenario))
    assert travelled.map_points == scenario.map_points and travelled.world == ""
    first, second = simulate(scenario), simulate(travelled)
    assert first.metrics["success"]
    np.testing.assert_array_equal(first.positions, second.positions)


def test_a_pcd_map_loads_as_the_same_ply_map(tmp_path):
    from pypcd4 import PointCloud

    points = np.random.default_rng(2).normal(size=(300, 3)).astype(np.float32)
    points[:, 0] += 4.0  # clear of the start and the goal
    PointCloud.from_xyz_points(points).save(str(tmp_path / "map.pcd"))
    pcd = load_scenario(_mapped(tmp_path, name="map.pcd"))
    ply = load_scenario(_mapped(tmp_path, points, name="map.ply"))
    assert pcd.map_points == ply.map_points
    np.testing.assert_array_equal(
        pcd.map_points, downsample(points.astype(float), 0.05)
    )


def test_a_million_points_load(tmp_path):
    """A map of 1e6 points loads (read, checked, thinned): time and memory
    printed (benchmarks/point_map.py --measure also flies it)."""
    wall = load_scenario(os.path.join(SCENARIOS, "planar_wall.yaml"))
    path = _mapped(tmp_path, surface_samples(wall, 1_000_000, seed=4))
    tracemalloc.start()
    start = time.perf_counter()
    scenario = load_scenario(path)
    seconds = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    print(
        f"1e6 points: {seconds:.2f} s, peak {peak:.0f} MB, "
        f"{len(scenario.map_points)} kept"
    )
    # The wall's 26.8 m² of surface holds at most ~26.8 / 0.05² voxels.
    assert 0 < len(scenario.map_points) < 1.2 * 26.8 / 0.05**2


def _nan_map(tmp_path):
    points = np.ones((10, 3))
    points[:, 1] = np.nan
    points[3, 0] = np.inf
    write_ply(str(tmp_path / "map.ply"), points)


BAD_MAPS = [
    ("missing", None, "", "no such file"),
    (
        "unreadable",
        lambda t: (t / "map.ply").write_text("ply\nnonsense\n"),
        "",
        "not readable as a point cloud",
    ),
    (
        "empty",
        lambda t: write_ply(str(t / "map.ply"), np.zeros((0, 3))),
        "",
        "holds no points",
    ),
    ("not finite", _nan_map, "", "holds no finite point (all 10 are NaN or inf)"),
    (
        "cameras",
        "wall",
        "sensor: !DepthCamera {}\n",
        "a point-cloud map flies with no cameras",
    ),
    (
        "obstacles",
        "wall",
        "obstacles:\n  - shape: !Sphere {radius: 0.3}\n    position: [2, 2, 2]\n",
        "a point-cloud map flies with no obstacles",
    ),
    (
        "ground",
        "wall",
        "ground: {height: 0.0}\n",
        "a point-cloud map flies with no ground",
    ),
]


@pytest.mark.parametrize(
    "label, make, extra, needle", BAD_MAPS, ids=[b[0] for b in BAD_MAPS]
)
def test_a_bad_map_is_one_line_and_exit_2(tmp_path, capsys, label, make, extra, needle):
    path = tmp_path / "mapped.yaml"
    path.write_text(f"{HEAD}world: map.ply\n{extra}")
    if make == "wall":
        _mapped(tmp_path, extra=extra)
    elif make is not None:
        make(tmp_path)
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"{path}: world = 'map.ply': {needle}" in err
    assert not out.exists()


def test_a_goal_at_a_map_point_is_refused_in_one_line(tmp_path, capsys):
    """A goal 0.2 m from a map point (inside the collision radius) is
    refused, naming the point; 1 m away it is accepted."""
    points = np.array([[8.2, 0.0, 1.5], [9.0, 3.0, 1.5]])
    path = _mapped(tmp_path, points)
    assert main(["run", path, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert (
        "goal = [8.0, 0.0, 1.5]: is 0.200 m from the map's point [8.2, 0.0, 1.5]" in err
    )
    points[0, 0] = 9.0
    path = _mapped(tmp_path, points)
    assert load_scenario(path).map_points == points.tolist()


def test_map_points_written_inline_are_checked():
    scenario = dataclasses.replace(
        sc.Scenario(goal=[1.0, 0.0, 1.5]), map_points=[[0.0, 0.0, float("inf")]]
    )
    with pytest.raises(sc.ScenarioError, match=r"x: map_points\[0\] = .*finite"):
        sc.check_scenario(scenario, "x")


def test_the_figure_draws_the_map_as_points():
    """The top view's first collection is the map's scatter: every point's
    x and y (the shipped map is under MAP_DRAWN points)."""
    from mfi_drake.app.figures import flights_figure

    scenario = load_scenario(os.path.join(SCENARIOS, "planar_wall_map.yaml"))
    ax_top = flights_figure(scenario, []).axes[1]
    drawn = ax_top.collections[0].get_offsets()
    np.testing.assert_array_equal(drawn, np.asarray(scenario.map_points)[:, :2])


def test_las_and_laz_surveys_load_as_the_same_ply_map(tmp_path):
    """An aerial survey's LAS (integers scaled by 1 mm about an offset) and
    its LAZ (compressed) load as the points they store, thinned (an
    upper-case suffix, as scanners write it, too)."""
    import laspy

    rng = np.random.default_rng(5)
    points = np.round(rng.uniform([3, -2, 0], [6, 2, 3], (400, 3)), 3)
    header = laspy.LasHeader(point_format=0, version="1.2")
    header.scales, header.offsets = [0.001] * 3, [500000.0, 0.0, 0.0]
    survey = laspy.LasData(header)
    survey.x, survey.y, survey.z = points.T
    survey.write(str(tmp_path / "map.LAS"))
    survey.write(str(tmp_path / "map.laz"))
    las = load_scenario(_mapped(tmp_path, name="map.LAS"))
    laz = load_scenario(_mapped(tmp_path, name="map.laz"))
    assert las.map_points == laz.map_points
    np.testing.assert_allclose(las.map_points, downsample(points, 0.05), atol=1e-9)


def test_text_clouds_load_as_the_same_ply_map(tmp_path):
    """A scan exported as text: XYZ (a comment, commas, intensity and
    colour columns not read) and PTS (its first line the count of points,
    a point without a return as nan: left out and said), both the points
    the PLY holds."""
    points = np.round(
        np.random.default_rng(7).uniform([3, -2, 0], [6, 2, 3], (300, 3)), 6
    )
    rows = [f"{x},{y},{z},0.5,200,10,10" for x, y, z in points]
    (tmp_path / "scan.xyz").write_text("// exported\n" + "\n".join(rows) + "\n")
    rows = [f"{x} {y} {z} 12 200 10 10" for x, y, z in points] + ["nan nan nan 0 0 0 0"]
    (tmp_path / "scan.PTS").write_text(f"{len(rows)}\n" + "\n".join(rows) + "\n")
    ply = load_scenario(_mapped(tmp_path, points, name="map.ply"))
    xyz = load_scenario(_mapped(tmp_path, name="scan.xyz"))
    with pytest.warns(ScenarioWarning, match="1 "):
        pts = load_scenario(_mapped(tmp_path, name="scan.PTS"))
    assert xyz.map_points == pts.map_points  # the PLY's are float32:
    np.testing.assert_allclose(xyz.map_points, ply.map_points, atol=1e-6)
    np.testing.assert_allclose(xyz.map_points, downsample(points, 0.05), atol=1e-12)
