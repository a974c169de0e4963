"""The escape rule's door detector and its passage (maths.escape.door,
phase PASS; docs/nonconvex.md, "The escape rule", rule 7)."""

import numpy as np
import pytest

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import Ground
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths import escape, escape_steering
from mfi_drake.maths.layout import obstacle_signal
from mfi_drake.world.nonconvex import room

RULE = escape.EscapeParams()
RADIUS = VEHICLES["drake_default"].collision_radius
GOAL = np.array([0.5, 5.0, 1.5])  # beyond a wall along y = 0
P = np.array([0.0, -0.7, 1.5])  # 0.7 m before the near jamb's edge (the origin)
STEP = np.array([0.05, 0.0, 0.0])  # the last step: along the wall, +x


def following(surface_moved=(0.0, 0.0, 0.0), width=1.0):
    """The memory of a vehicle following the near jamb about +e_z whose
    closest point was `surface_moved` from the origin at the last step, the
    far jamb's `width` along +x, where it is now."""
    memory = escape.initial_memory(P - STEP, GOAL)
    memory[escape.PHASE] = escape.FOLLOW
    memory[escape.D_HIT] = 0.1  # never leave
    memory[escape.SURFACE] = np.array([0.0, 0.0, 1.5]) + surface_moved
    memory[escape.SURFACE_SEEN] = 1.0
    memory[escape.LAST_P] = P - STEP
    last = [[0.0, 0.0, 1.5], [width, 0.0, 1.5], [np.inf] * 3]
    memory[escape.LAST_POINTS] = np.ravel(last)
    return memory


def jambs(width):
    """The readings at P: the near jamb's edge at the origin (height 1.5),
    the far jamb's `width` along +x."""
    near = np.array([0.0, 0.0, 1.5]) - P
    return obstacle_signal([near, near + [width, 0.0, 0.0]])


@pytest.mark.parametrize("width", [1.0, 1.1, 1.6])
def test_a_door_by_hand(width):
    """An edge rounded (its closest point stayed put while the vehicle moved
    0.05 m along the wall) and the far jamb `width` away: a door, its middle
    halfway along, the way through ⟂ the wall (+y); the memory passes it,
    its subgoal on the line through the middle, PASS_AHEAD past the wall."""
    found = escape.door(following(width=width), jambs(width), P, escape.E_Z, RADIUS)
    middle = np.array([width / 2, 0.0, 1.5])
    assert found[0] == pytest.approx(middle)
    assert found[1] == pytest.approx([0.0, 1.0, 0.0])
    memory = escape.update_memory(
        following(width=width), 20.0, P, STEP / 0.05, jambs(width), GOAL, RADIUS, RULE
    )
    assert memory[escape.PHASE] == escape.PASS
    target = escape_steering.subgoal(memory, P, jambs(width), GOAL, RADIUS, RULE)
    assert target == pytest.approx(middle + [0.0, escape.PASS_AHEAD, 0.0])
    # Through: PASS_BEYOND past the middle, toward the goal again.
    beyond = middle + [0.0, escape.PASS_BEYOND + 0.01, 0.0]
    after = escape.update_memory(
        memory, 21.0, beyond, STEP, jambs(9), GOAL, RADIUS, RULE
    )
    assert after[escape.PHASE] == escape.TOWARD
    # The door passed is not passed again.
    assert escape.door(after, jambs(width), P, escape.E_Z, RADIUS) is None


def test_no_door_at_a_face_a_narrow_gap_or_a_corner():
    """A face (its closest point moved with the vehicle), a gap narrower
    than 2R + GAP_MARGIN, a far reading that is a face, and a concave
    corner (two faces' feet 0.95 m apart, what a 1 m door also looks like
    in one reading): no door."""
    assert escape.door(following(STEP), jambs(1.0), P, escape.E_Z, RADIUS) is None
    narrow = 2 * RADIUS + escape.GAP_MARGIN - 0.01
    memory = following(width=narrow)
    assert escape.door(memory, jambs(narrow), P, escape.E_Z, RADIUS) is None
    # The far reading a face (moved with the vehicle): a baffle's root wall.
    memory = following()
    memory[escape.LAST_POINTS][3] -= STEP[0]
    assert escape.door(memory, jambs(1.0), P, escape.E_Z, RADIUS) is None
    corner = obstacle_signal([np.array([0.0, 0.7, 0.0]), np.array([0.67, 0.0, 0.0])])
    memory = following(STEP)
    memory[escape.SURFACE] = P + [-0.05, 0.7, 0.0]  # the foot on the wall at +y
    assert escape.door(memory, corner, P, escape.E_Z, RADIUS) is None


# (door width [m], the room's yaw [deg]): doors narrower than 2 (R + r_f) =
# 1.34 m, met side-on. With the detector off (DOOR_WIDEST = 0) none of the
# three reaches the goal in the 40 s (6.3, 0.17 and 3.9 m from it).
DOORS = [(1.0, 0.0), (1.1, 30.0), (1.1, 120.0)]


@pytest.mark.parametrize(("width", "yaw_deg"), DOORS)
def test_mfi_nc_passes_a_narrow_door_met_side_on(width, yaw_deg):
    """From inside a room, the rule follows the wall the goal lies beyond,
    rounds the corner and meets the door side-on: it detects the door and
    passes it, reaching the goal without contact within 40 s."""
    world = side_door_room(width, yaw_deg)
    metrics = simulate(world, "mfi", until_settled=True).metrics
    assert metrics["outcome"] == "success", metrics["final_error"]
    assert metrics["min_clearance"] > 0.0


def side_door_room(width: float, yaw_deg: float) -> sc.Scenario:
    """The start inside a 4 × 4 × 3 m room on the ground, the goal 3 m
    outside its +x wall; the one door, `width` wide and 2.2 m high, in the
    +y wall near the +x corner: MFI stalls at the +x wall, and the rule,
    following round it, meets the door side-on. Yawed by `yaw_deg` about
    the start."""
    goal = np.append(_turn(yaw_deg, (5.0, 0.0)), 1.5)
    return sc.Scenario(
        name=f"side_door_{width}_{yaw_deg}",
        start=[0.0, 0.0, 1.5],
        goal=goal.tolist(),
        duration=40.0,
        obstacles=room((0.0, 0.0), 4.0, 4.0, 3.0, yaw_deg, 1, 0.1, width, 2.2),
        ground=Ground(height=0.0),
        escape=escape.EscapeParams(stall_time=5.0),
    )


def _turn(yaw_deg: float, xy) -> np.ndarray:
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    return np.array([c * xy[0] - s * xy[1], s * xy[0] + c * xy[1]])
