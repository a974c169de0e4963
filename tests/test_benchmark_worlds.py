"""The benchmark classes' generated worlds (world.benchmark_worlds: BARN-like
clutter in a slab, indoor floor plans) and the BARN converter
(benchmarks/barn.py). The oracles: SceneGraph's exact distances on a grid
at the flight height (a second method, not the generator's own
construction) say a disc of the vehicle's collision radius can go from
start to goal; a hand-written world file converts to the cylinders and
slab it holds, and its widest passage is the closed-form gap."""

import numpy as np
import pytest
from scipy import ndimage

from mfi_drake.config import scenario as sc
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.studies import sweep
from mfi_drake.world.benchmark_worlds import KINDS, benchmark_world
from mfi_drake.world.obstacles import obstacle_distances

from .conftest import load_benchmark

RADIUS = VEHICLES["drake_default"].collision_radius
STEP = 0.05  # m, the grid


def passable(scenario: sc.Scenario, *cells) -> bool:
    """Whether the start, the goal and the points `cells` lie in one
    8-connected component of the grid points at the start's height with
    more than the collision radius of clearance."""
    z = scenario.start[2]
    ends = np.array([scenario.start, scenario.goal, *cells])[:, :2]
    lo, hi = ends.min(axis=0) - 3.0, ends.max(axis=0) + 3.0
    xs, ys = np.arange(lo[0], hi[0], STEP), np.arange(lo[1], hi[1], STEP)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    points = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, z)])
    distances = np.array(obstacle_distances(scenario, points, within=RADIUS + 0.1))
    free = (distances > RADIUS).reshape(gx.shape)
    labels, _ = ndimage.label(free, structure=np.ones((3, 3)))
    index = np.round((ends - lo) / STEP).astype(int)
    found = {labels[i, j] for i, j in index}
    return len(found) == 1 and 0 not in found


@pytest.mark.parametrize("index", [0, 1])
def test_a_clutter_world_is_a_dense_slab_with_a_passage(index):
    world = benchmark_world("clutter", 0, index)
    posts = [o for o in world.obstacles if isinstance(o.shape, sc.Cylinder)]
    assert len(posts) > 60  # dense: BARN's fields hold 200-300
    assert all(o.shape.radius == 0.075 for o in posts)
    # Floor and ceiling 1 m apart, the flight height in the middle.
    assert obstacle_distances(world, [world.start]) == pytest.approx([0.5])
    assert np.linalg.norm(np.subtract(world.goal, world.start)) == pytest.approx(10)
    assert passable(world)
    # Seeded: the same world twice, another for another index.
    assert benchmark_world("clutter", 0, index).obstacles == world.obstacles
    assert benchmark_world("clutter", 0, index + 2).obstacles != world.obstacles


def test_a_floor_plan_joins_every_room_by_doors():
    world = benchmark_world("floorplan", 0, 0)
    assert world.ground is not None
    heights = [o.position[2] for o in world.obstacles]
    assert max(heights) > 2.5  # the ceiling's box over the walls
    cell = 2 * world.start[0]  # the start is the first room's middle
    rooms = [
        (cell * (i + 0.5), cell * (j + 0.5))
        for i in range(round(world.goal[0] / cell + 0.5))
        for j in range(round(world.goal[1] / cell + 0.5))
    ]
    assert len(rooms) >= 6
    assert passable(world, *[(x, y, world.start[2]) for x, y in rooms])


def test_sweep_flies_the_benchmark_classes():
    for kind in KINDS:
        assert kind in sweep.WORLDS
        config = sweep.SweepConfig(n=2, methods=["mfi"], world=kind)
        assert {(k.world, k.index) for k in config.flight_keys()} == {
            (kind, 0),
            (kind, 1),
        }


WORLD = """<?xml version="1.0"?>
<sdf version="1.6"><world name="default">
  <model name="ground_plane"><static>1</static><pose>0 0 0 0 0 0</pose>
    <link name="link"><collision name="c"><geometry><plane>
      <normal>0 0 1</normal></plane></geometry></collision></link></model>
  {models}
</world></sdf>
"""
CYLINDER = """<model name="unit_cylinder_{k}"><static>1</static>
  <pose>{x} {y} 0 0 0 0</pose><link name="link"><collision name="collision">
  <geometry><cylinder><radius>0.075</radius><length>1</length></cylinder>
  </geometry></collision></link></model>"""


def test_a_barn_world_converts_and_its_widest_passage_is_the_gap(tmp_path):
    """Hand case: the start walled in, as BARN's are (rows of cylinders
    every 0.15 m at y = 0 and y = 8 between columns at x = -6 and x = 1.5),
    with one gap in the row at y = 8: the widest disc out passes between
    the cylinders either side of it, axes 2w apart, radius w - 0.075."""
    barn = load_benchmark("barn")
    xs = np.round(np.arange(-6.0, 1.51, 0.15), 3)
    ys = np.round(np.arange(0.15, 7.9, 0.15), 3)
    axes = (-2.7, -1.8)  # the gap's two sides: w = 0.45, radius 0.375
    top = xs[(xs <= axes[0]) | (xs >= axes[1])]
    points = [(x, 8.0) for x in top] + [(x, 0.0) for x in xs]
    points += [(x, y) for x in (xs[0], xs[-1]) for y in ys]
    models = "\n".join(
        CYLINDER.format(k=k, x=x, y=y) for k, (x, y) in enumerate(points)
    )
    path = tmp_path / "world_1.world"
    path.write_text(WORLD.format(models=models))
    posts = barn.cylinders(str(path))
    assert len(posts) == len(points)  # the ground plane is no cylinder
    scenario = barn.barn_scenario(str(path), "barn_1")
    assert scenario.start == [-2.25, 3.0, 0.0] and scenario.goal == [-2.25, 13.0, 0.0]
    assert len(scenario.obstacles) == len(points) + 2  # the floor, the ceiling
    assert obstacle_distances(scenario, [scenario.start]) == pytest.approx([0.5])
    assert barn.widest_passage(posts) == pytest.approx(0.375, abs=barn.CELL)


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--set", "escape: {door_brak: 1}"], "escape.door_brak = 1"),
        (["--worlds", "7"], "world_7.world"),
    ],
)
def test_barn_refuses_bad_input_in_one_line_before_flying(
    tmp_path, monkeypatch, capsys, extra, named
):
    """An unknown field in --set, or a world file that is not there: exit
    status 2 and one line naming it, before any flight (no output folder)."""
    barn = load_benchmark("barn")
    path = tmp_path / "world_1.world"
    path.write_text(WORLD.format(models=CYLINDER.format(k=0, x=0.0, y=5.0)))
    out = tmp_path / "out"
    argv = ["barn.py", str(tmp_path), "--worlds", "1", "--out", str(out), *extra]
    monkeypatch.setattr("sys.argv", argv)
    with pytest.raises(SystemExit) as error:
        barn.main()
    assert error.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert named in lines[-1] and "Traceback" not in "\n".join(lines)
    assert not out.exists()
