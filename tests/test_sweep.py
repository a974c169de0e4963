"""The Monte Carlo sweep: the field generator's guarantees, the reference path
against closed forms, the statistics against hand-computed values, the
results file's resume, and a sweep on two Dask worker processes."""

import dataclasses
import json
import math
import os
import sys

import numpy as np
import pytest

from mfi_drake.app.cli import main
from mfi_drake.app.figures import plot_sweep
from mfi_drake.config import scenario as sc
from mfi_drake.config.faults import Faults
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.studies import cluster as study_cluster
from mfi_drake.studies import records as record_store
from mfi_drake.studies import stats as sweep_stats
from mfi_drake.studies import sweep, variants
from mfi_drake.world import generator
from mfi_drake.world.meshes import prism, write_obj
from mfi_drake.world.obstacles import obstacle_distances
from mfi_drake.world.reference_path import Clearance, reference_path
from mfi_drake.world.shapes import bounding_radius, shape_mesh
from mfi_drake.world.validation import load_scenario, validate_scenario

from .conftest import load_benchmark

R = VEHICLES["drake_default"].collision_radius
W = generator.DEFAULT_WORKSPACE


# --- the generator ----------------------------------------------------------------
@pytest.mark.parametrize("index", range(4))
def test_start_and_goal_are_free_with_clearance(index):
    field = generator.random_field(3, index, 0.3)
    assert len(field.obstacles) == round(0.3 * 200.0) == 60
    d_start, d_goal = obstacle_distances(field, [field.start, field.goal])
    assert min(d_start, d_goal) >= R + W.clearance
    # and obstacles do crowd the line: some come within 1.5 m of the start.
    assert min(obstacle_distances(field, [[1.5, 0.0, W.height]])) < 1.0
    validate_scenario(field, field.name)


def test_wall_fields_block_the_line_far_from_the_ends_and_are_reproducible():
    for index in range(50):
        field = generator.wall_field(5, index)
        assert field.obstacles == generator.wall_field(5, index).obstacles
        (wall,) = field.obstacles
        d_start, d_goal = obstacle_distances(field, [field.start, field.goal])
        assert min(d_start, d_goal) >= 3.0  # the docstring's bound, ≈ 3.4 m
        clearance = Clearance(field, R)
        # The line is blocked, and it still is WALL_OVERLAP less a little in
        # from each side of the crossing: the wall reaches past it each way.
        ends = np.array(field.start), np.array(field.goal)
        assert clearance.blocked_fraction(*ends, 0.01) > 0
        yaw = np.radians(wall.rpy_deg[2])
        along = np.array([-np.sin(yaw), np.cos(yaw), 0.0])  # the wall's length
        # Where the line meets the wall's mid-plane, and points 0.4 m from it
        # along the wall and up and down: all inside the wall.
        hit = np.array([wall.position[0] + wall.position[1] * np.tan(yaw), 0, W.height])
        for step in [0.4 * along, -0.4 * along, [0, 0, 0.4], [0, 0, -0.4], 0 * along]:
            assert min(obstacle_distances(field, [hit + step])) < 0
        validate_scenario(field, field.name)
    assert generator.wall_field(5, 0).obstacles != generator.wall_field(6, 0).obstacles


def test_same_seed_same_field_other_index_other_field():
    a = generator.random_field(7, 2, 0.1)
    b = generator.random_field(7, 2, 0.1)
    c = generator.random_field(7, 3, 0.1)
    assert a.obstacles == b.obstacles  # same shapes (vertices too) and poses
    assert any(isinstance(o.shape, sc.Convex) for o in a.obstacles)
    assert [o.position for o in a.obstacles] != [o.position for o in c.obstacles]
    # A denser field of the same seed and index holds the sparser one.
    denser = generator.random_field(7, 2, 0.2)
    assert [o.position for o in denser.obstacles[:20]] == [
        o.position for o in a.obstacles
    ]


def _is_convex(vertices: np.ndarray, triangles: np.ndarray) -> bool:
    """Every vertex on the inner side of every face plane."""
    centre = vertices.mean(axis=0)
    for t in triangles:
        a, b, c = vertices[t]
        normal = np.cross(b - a, c - a)
        if np.dot(normal, centre - a) > 0:
            normal = -normal
        if np.max((vertices - a) @ normal) > 1e-9 * np.linalg.norm(normal):
            return False
    return True


def test_every_shape_kind_appears_randomly_oriented_and_meshes_are_convex():
    fields = [generator.random_field(0, i, 0.1) for i in range(3)]
    obstacles = [o for f in fields for o in f.obstacles]
    kinds = {type(o.shape).__name__.lower() for o in obstacles}
    assert kinds == {kind.name for kind in generator.SHAPE_KINDS}
    tilted = [o for o in obstacles if not isinstance(o.shape, sc.Sphere)]
    assert all(any(abs(a) > 1e-9 for a in o.rpy_deg) for o in tilted)
    meshes = [o.shape for o in obstacles if isinstance(o.shape, sc.Convex)]
    assert meshes and all(m.vertices and not m.file for m in meshes)  # inline
    # The prisms and icosahedra are their own hulls: every vertex is one of
    # the hull's (Drake's), and the hull is convex (the independent check).
    for m in meshes:
        hull = shape_mesh(fields[0], m)
        assert _is_convex(*hull)
        assert len(hull[0]) == len(m.vertices)
    low, high = W.box
    for o in obstacles:
        assert np.all(low <= o.position) and np.all(o.position <= high)


def test_written_field_is_one_file_that_loads_back_equal(tmp_path):
    field = generator.random_field(5, 1, 0.15)
    path = tmp_path / "out" / "field.yaml"
    generator.write_scenario(field, str(path), header="# a comment\n")
    assert os.listdir(path.parent) == ["field.yaml"]  # no mesh files beside it
    moved = tmp_path / "elsewhere" / "copy.yaml"  # flies from anywhere
    moved.parent.mkdir()
    path.rename(moved)
    loaded = load_scenario(str(moved))
    for f in dataclasses.fields(sc.Scenario):
        if f.name not in ("base_dir", "simulator"):
            assert getattr(loaded, f.name) == getattr(field, f.name), f.name
    assert repr(loaded.simulator) == repr(field.simulator)
    assert any(isinstance(o.shape, sc.Convex) for o in loaded.obstacles)


def test_self_contained_inlines_mesh_files_and_keeps_the_geometry(tmp_path):
    """A scenario's OBJ files become inline vertices: the same exact
    distances (Drake's hull of the same points), the same bounding radii,
    and the written replay is one file."""
    (tmp_path / "meshes").mkdir()
    cube = tmp_path / "meshes" / "cube.obj"
    write_obj(str(cube), *prism(np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]), 2))
    wedge = sc.Convex(file="meshes/cube.obj", scale=0.5)
    scenario = sc.Scenario(
        goal=[6.0, 0.0, 1.5],
        obstacles=[sc.Obstacle(wedge, [3.0, 0.2, 1.4], [10.0, 20.0, 30.0])],
        base_dir=str(tmp_path),
    )
    inline = generator.self_contained(scenario)
    (obstacle,) = inline.obstacles
    assert not obstacle.shape.file and obstacle.shape.scale == 0.5
    assert len(obstacle.shape.vertices) == 8 and inline.base_dir == ""
    points = np.random.default_rng(1).uniform(-1, 6, (50, 3)).tolist()
    assert obstacle_distances(inline, points) == obstacle_distances(scenario, points)
    assert bounding_radius(inline, obstacle.shape) == pytest.approx(math.sqrt(3) / 2)
    generator.write_scenario(scenario, str(tmp_path / "replay" / "r.yaml"))
    assert os.listdir(tmp_path / "replay") == ["r.yaml"]
    os.remove(cube)  # the replay reads no file
    replay = load_scenario(str(tmp_path / "replay" / "r.yaml"))
    assert obstacle_distances(replay, points) == obstacle_distances(inline, points)


# --- the reference path -------------------------------------------------------------
def _sphere_on_line(a: float):
    """Sphere of radius a midway on a 10 m line: tangent, arc, tangent."""
    field = sc.Scenario(
        start=[0, 0, 2],
        goal=[10, 0, 2],
        obstacles=[sc.Obstacle(sc.Sphere(a), [5, 0, 2])],
    )
    rho, d = a + R, 5.0
    exact = 2 * math.sqrt(d * d - rho * rho) + rho * (math.pi - 2 * math.acos(rho / d))
    return field, exact


def _wall_across_line(t: float, w: float):
    """A tall wall t thick, w wide: round its grown vertical edge in the plane
    z = 2 (two tangents, two arcs of radius R, the wall's thickness)."""
    field = sc.Scenario(
        start=[0, 0, 2],
        goal=[10, 0, 2],
        obstacles=[sc.Obstacle(sc.Box([t, w, 10.0]), [5, 0, 2])],
    )
    corner = math.hypot(5 - t / 2, w / 2)
    turn = math.atan2(w / 2, 5 - t / 2) + math.asin(R / corner)
    exact = 2 * (math.sqrt(corner**2 - R * R) + R * turn) + t
    return field, exact


@pytest.mark.parametrize(
    "field, exact",
    [_sphere_on_line(1.0), _sphere_on_line(0.4), _wall_across_line(0.2, 4.0)],
    ids=["sphere_1m", "sphere_0.4m", "wall"],
)
def test_reference_path_matches_the_closed_form(field, exact):
    ref = reference_path(field)
    assert ref.length == pytest.approx(exact, rel=1e-3)
    # Each step shortens the path; the grid alone is far off.
    assert ref.grid_length > ref.shortcut_length >= ref.length
    assert ref.grid_length > 1.05 * exact
    clearance = Clearance(field, R)
    for a, b in zip(ref.points[:-1], ref.points[1:], strict=True):
        assert clearance.segment_free(a, b, 2e-3)
    np.testing.assert_array_equal(ref.points[[0, -1]], [field.start, field.goal])


def test_reference_path_is_straight_without_obstacles_in_the_way():
    field = sc.Scenario(
        start=[0, 0, 2],
        goal=[10, 0, 2],
        obstacles=[sc.Obstacle(sc.Sphere(0.5), [5, 3, 2])],
    )
    ref = reference_path(field)
    assert ref.length == pytest.approx(10.0, abs=1e-9)
    np.testing.assert_array_equal(ref.points, [field.start, field.goal])


# --- statistics ---------------------------------------------------------------------
def test_wilson_interval_matches_hand_computed_values():
    # k = 0: upper end z²/(n + z²); k = n/2: symmetric about 1/2.
    assert sweep_stats.wilson_interval(0, 30) == pytest.approx(
        [0.0, 0.113513], abs=1e-6
    )
    assert sweep_stats.wilson_interval(30, 30) == pytest.approx(
        [0.886487, 1.0], abs=1e-6
    )
    assert sweep_stats.wilson_interval(15, 30) == pytest.approx(
        [0.331541, 0.668459], abs=1e-6
    )
    assert sweep_stats.wilson_interval(0, 0) is None
    for n in (1, 7, 30, 199, 200):  # always holds the observed rate
        for k in range(n + 1):
            lo, hi = sweep_stats.wilson_interval(k, n)
            assert 0.0 <= lo <= k / n <= hi <= 1.0


def test_median_interval_uses_ranks_40_and_61_of_100():
    values = np.arange(1.0, 101.0)[::-1]  # unsorted on purpose
    assert sweep_stats.median_interval(values) == [40.0, 61.0]
    assert sweep_stats.median_interval([]) is None


# --- running sweeps -----------------------------------------------------------------
def _short(scenario: sc.Scenario) -> sc.Scenario:
    """A 1.5 s flight: cheap, and a timeout (the goal is 10 m away)."""
    return dataclasses.replace(scenario, duration=1.5)


def test_rerun_after_a_kill_flies_only_the_rest(tmp_path, threads_client):
    config = sweep.SweepConfig(n=2, seed=4, methods=["mfi", "apf"], out=str(tmp_path))
    first = sweep.run_sweep(
        config, threads_client, modify=_short, progress_stream=sys.stdout
    )
    assert (first.ran, first.skipped, first.lost) == (4, 0, [])
    results = tmp_path / "results.jsonl"
    lines = results.read_text().splitlines(keepends=True)
    assert len(lines) == 4
    # A kill after two flights, in the middle of writing the third line.
    results.write_text("".join(lines[:2]) + lines[2][:40])
    again = sweep.run_sweep(
        config, threads_client, modify=_short, progress_stream=sys.stdout
    )
    assert (again.ran, again.skipped) == (2, 2)
    now = results.read_text().splitlines(keepends=True)
    assert now[:2] == lines[:2]
    assert len(now) == 4 and all(line.endswith("\n") for line in now)
    # The flights flown again give the same outcomes (deterministic simulation).
    strip = ("wall_time",)
    redo = sorted(
        json.dumps({k: v for k, v in json.loads(x).items() if k not in strip})
        for x in now[2:]
    )
    orig = sorted(
        json.dumps({k: v for k, v in json.loads(x).items() if k not in strip})
        for x in lines[2:]
    )
    assert redo == orig
    # A third run has nothing left to do.
    third = sweep.run_sweep(
        config, threads_client, modify=_short, progress_stream=sys.stdout
    )
    assert (third.ran, third.skipped) == (0, 4)
    # Every flight timed out; each is saved as a replayable scenario.
    assert third.summary["methods"]["mfi"]["timeout_rate"] == 1.0
    yamls = sorted(os.listdir(tmp_path / "failures"))
    assert len(yamls) == 4 and all(f.endswith(".yaml") for f in yamls)
    # The out folder holds these files only: no mesh files anywhere.
    assert set(os.listdir(tmp_path)) == {
        "results.jsonl", "summary.json", "table.md", "failures"
    }  # fmt: skip
    replay = load_scenario(str(tmp_path / "failures" / yamls[0]))
    assert replay.duration == 1.5
    assert "--method" in (tmp_path / "failures" / yamls[0]).read_text().splitlines()[1]


def test_two_worker_sweep_records_every_flight(tmp_path):
    config = sweep.SweepConfig(
        n=2, seed=9, methods=["mfi", "gf"], densities=[0.05, 0.1], out=str(tmp_path)
    )
    with study_cluster.dask_client(2, None) as client:
        pids = set(client.run(os.getpid).values())
        run = sweep.run_sweep(config, client, modify=_short, progress_stream=sys.stdout)
    assert len(pids) == 2 and os.getpid() not in pids
    assert (run.ran, run.lost) == (8, [])
    records = record_store.read_results(str(tmp_path / "results.jsonl"))
    assert sorted(record_store.record_key(r) for r in records) == sorted(
        config.flight_keys()
    )
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary == json.loads(json.dumps(run.summary))
    for method in config.methods:
        for stats in summary["methods"][method]["by_density"].values():
            rates = [stats[f"{o}_rate"] for o in record_store.OUTCOMES]
            assert stats["n"] == 2 and sum(rates) == pytest.approx(1.0)
    assert "| mfi | 0.05 | 2 |" in (tmp_path / "table.md").read_text()
    plot_sweep(summary, str(tmp_path / "sweep.png"))
    assert (tmp_path / "sweep.png").read_bytes().startswith(b"\x89PNG")


# --- the command line ---------------------------------------------------------------
def test_sweep_without_dask_is_one_line_with_the_install_command(
    tmp_path, monkeypatch, capsys
):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import fails
    assert main(["sweep", "--n", "1", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "pip install" in err


@pytest.mark.parametrize(
    "args, named",
    [
        (["--n", "0"], "--n"),
        (["--density", "-0.1"], "--density"),
        (["--methods", "mfi,xyz"], "--methods"),
        (["--seed", "-1"], "--seed"),
    ],
)
def test_sweep_rejects_bad_arguments(tmp_path, capsys, args, named):
    assert main(["sweep", "--out", str(tmp_path), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and named in err
    assert not os.path.exists(tmp_path / "results.jsonl")


def test_obstacle_count_benchmark_flies_the_same_path_in_every_world(capsys):
    results = load_benchmark("obstacle_count").main(
        ["--counts", "10", "40", "--repeats", "1", "--duration", "2"]
    )
    assert "same trajectory in every world: yes" in capsys.readouterr().out
    assert results[10]["steps"] == results[40]["steps"] > 0


def test_a_long_or_path_like_variant_names_its_failure_file_by_a_hash(tmp_path):
    config = sweep.SweepConfig(out=str(tmp_path))
    field = sc.Scenario(name="field_d0.2_s100_i7")
    names = {}
    for variant in ("sensor_noise_std=0.05", "x" * 200, "navigator: {c: 2}/x"):
        key = record_store.FlightKey(variant, "depth", 0.2, 100, 7, "mfi")
        names[variant] = os.path.basename(sweep._failure_path(config, key, field))
    assert names["sensor_noise_std=0.05"] == (
        "sensor_noise_std=0.05_depth_mfi_field_d0.2_s100_i7.yaml"
    )
    for variant in ("x" * 200, "navigator: {c: 2}/x"):
        assert names[variant].startswith("variant-") and len(names[variant]) < 64
    assert names["x" * 200] != names["navigator: {c: 2}/x"]


def test_variant_names_join_motion_overrides_and_faults_in_that_order():
    """The names records are keyed by (resuming a sweep finds its flights by
    them): each part as its own function names it, "" when none."""
    set_text = [("--set", "navigator: {c: 2}")]
    faults = Faults(position_noise_std=0.05)
    motion = variants.motion_variant(0.3, 0.5)
    assert variants.variant_name() == ""
    assert variants.variant_name(set_text, faults, motion) == (
        "moving=0.3,obstacle_speed=0.5,navigator: {c: 2},position_noise_std=0.05"
    )
    assert variants.variant_name(faults=faults) == "position_noise_std=0.05"
