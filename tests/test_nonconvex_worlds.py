"""The non-convex world generator (world.nonconvex, docs/nonconvex.md)."""

import numpy as np
import pytest

from mfi_drake.config.scenario_yaml import scenario_to_yaml
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.world import nonconvex as nc
from mfi_drake.world.obstacles import obstacle_distances
from mfi_drake.world.reference_path import Clearance, grid_path

RADIUS = VEHICLES["drake_default"].collision_radius
CELL = 0.2  # m, the connectivity grid


def connected(scenario, start, goal) -> bool:
    """Whether A* on a CELL grid round start and goal (6 m margin, above the
    ground) finds a path of the vehicle's centre keeping its collision
    radius: an oracle independent of how the world was drawn."""
    start, goal = np.asarray(start, float), np.asarray(goal, float)
    low = np.minimum(start, goal) - 6.0
    high = np.maximum(start, goal) + 6.0
    low[2] = max(low[2], 0.3)
    shape = tuple(int(x) for x in np.ceil((high - low) / CELL))
    try:
        grid_path(Clearance(scenario, RADIUS), start, goal, low, shape, CELL)
    except ValueError:
        return False
    return True


@pytest.mark.parametrize("kind", nc.KINDS)
def test_reproducible_and_distinct(kind):
    def text(seed, index):
        return scenario_to_yaml(nc.nonconvex_world(kind, seed, index))

    assert text(3, 1) == text(3, 1)
    assert text(3, 1) != text(3, 2)
    assert text(3, 1) != text(4, 1)


@pytest.mark.parametrize("kind", nc.KINDS)
@pytest.mark.parametrize("index", range(4))
def test_ends_free_and_connected(kind, index):
    world = nc.nonconvex_world(kind, 0, index)
    clear = obstacle_distances(world, [world.start, world.goal])
    assert min(clear) >= RADIUS + nc.CLEARANCE
    # Start and goal lie on the same side of everything: a path exists.
    assert connected(world, world.start, world.goal)


def test_rooms_are_closed_but_for_the_door():
    """A room holds its start or goal: with the door walled up no path
    leaves it (A* from inside, so the search is the room's inside)."""
    for index in range(3):
        sealed = nc.sealed_room(0, index)
        assert not connected(sealed, sealed.goal, sealed.start)
        entry = nc.nonconvex_world("room_entry", 0, index)
        assert connected(entry, entry.goal, entry.start)


def test_door_on_every_side_and_sizes_vary():
    """Over a few worlds the door faces each way from the room's centre
    relative to the start–goal line (+x), in rooms of many sizes. The door
    is where the lintel is: the one wall box that does not reach the
    ground and is not the ceiling."""
    sectors, sizes = set(), set()
    for kind in ("room_exit", "room_entry"):
        for index in range(8):
            world = nc.nonconvex_world(kind, 0, index)
            ceiling = world.obstacles[-1]
            lintel = [
                o
                for o in world.obstacles[:-1]
                if o.position[2] - o.shape.size[2] / 2 > 0.5
            ]
            assert len(lintel) == 1
            d = np.subtract(lintel[0].position[:2], ceiling.position[:2])
            angle = np.degrees(np.arctan2(d[1], d[0])) % 360.0
            sectors.add(int(((angle + 45.0) % 360.0) // 90.0))
            sizes.add(round(ceiling.shape.size[0] * ceiling.shape.size[1], 1))
    assert sectors == {0, 1, 2, 3}
    assert len(sizes) >= 12 and max(sizes) - min(sizes) > 20.0  # m²


def test_wall_holes():
    """A wall with a hole is the wall's boxes less the hole: a point in the
    hole is free, points beside it are inside a box."""
    world = nc.nonconvex_world("room_exit", 0, 0)
    pieces = nc.wall([0.0, 0.0], [4.0, 0.0], 0.0, 3.0, [(1.0, 2.0, 0.5, 2.0)])
    probe = world.__class__(goal=[9.0, 9.0, 9.0], obstacles=pieces)
    hole, beside, above = obstacle_distances(
        probe, [[1.5, 0.0, 1.25], [0.5, 0.0, 1.25], [1.5, 0.0, 2.5]]
    )
    assert hole == pytest.approx(0.5)  # to the hole's left and right edges
    assert beside < 0.0 and above < 0.0


def test_cups_open_toward_the_start_half_the_time():
    """ "cup" draws the hard case (mouth toward the start) about half the
    time: the mouth's direction, the cup frame's −x, has a negative x
    component in those."""
    toward = 0
    for index in range(20):
        world = nc.nonconvex_world("cup", 0, index)
        bottom = np.asarray(world.obstacles[0].position)
        side = np.asarray(world.obstacles[1].position)
        top = np.asarray(world.obstacles[3].position)
        # The centre of the cup lies on the line between opposite walls.
        centre = (side + np.asarray(world.obstacles[2].position)) / 2
        mouth = centre - bottom
        toward += mouth[0] < -0.5 * np.linalg.norm(mouth)
        assert np.linalg.norm(top - centre) > 1.0
    assert 6 <= toward <= 19


def test_unknown_kind_is_a_clear_error():
    with pytest.raises(ValueError, match="world = 'maze'"):
        nc.nonconvex_world("maze", 0, 0)
