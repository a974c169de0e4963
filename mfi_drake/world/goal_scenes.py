"""Goals near surfaces: a family of small scenes whose goal lies `gap` metres
from an obstacle surface (docs/goals.md).

Every scene starts at rest at START and has its goal at GOAL, 3.5 m along
+x at the same height; `gap` is the distance from the goal to the nearest
surface (the vehicle's clearance there is gap − its collision radius).
Walls are 0.2 m thick and 3 m tall boxes centred at the goal's height.
"""

import dataclasses
import math

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import Motion

START = (0.0, 0.0, 1.5)
GOAL = (3.5, 0.0, 1.5)
THICKNESS = 0.2  # m, of every wall
HEIGHT = 3.0  # m, of every wall
MOVING_RADIUS = 0.3  # m, the moving sphere's
MOVING_AMPLITUDE = 2.0  # m, of its swing across the approach
MOVING_FREQUENCY = 0.4  # rad/s: 0.8 m/s as it passes the goal
MOVING_PASS = 5.0  # s, when it first passes the goal


def _wall(size, x: float, y: float) -> sc.Obstacle:
    return sc.Obstacle(shape=sc.Box(size=[*size, HEIGHT]), position=[x, y, GOAL[2]])


def _ahead(gap: float, length: float = 4.0) -> sc.Obstacle:
    """A wall across the approach, its face `gap` beyond the goal."""
    return _wall([THICKNESS, length], GOAL[0] + gap + THICKNESS / 2, GOAL[1])


def _beside(gap: float, x_from: float, x_to: float, side: float = 1.0):
    """A wall along the approach from x_from to x_to, its face `gap` to the
    side (+y for side 1, −y for side −1) of the goal."""
    y = GOAL[1] + side * (gap + THICKNESS / 2)
    return _wall([x_to - x_from, THICKNESS], (x_from + x_to) / 2, y)


def _obstacles(layout: str, gap: float) -> list[sc.Obstacle]:
    gx = GOAL[0]
    if layout == "wall_ahead":
        return [_ahead(gap)]
    if layout == "wall_beside":
        return [_beside(gap, gx - 1.0, gx + 1.0)]
    if layout == "corner":  # concave: the two walls meet beyond the goal
        return [_ahead(gap), _beside(gap, gx - 1.5, gx + gap)]
    if layout == "sphere":
        radius = 0.8
        return [sc.Obstacle(sc.Sphere(radius), [gx, GOAL[1] + gap + radius, GOAL[2]])]
    if layout == "u_inside":  # open toward the start, arms 0.35 m farther
        arm = gap + 0.35
        back = _ahead(gap, length=2.0 * (arm + THICKNESS))
        return [back] + [_beside(arm, gx - 0.8, gx + gap, s) for s in (1.0, -1.0)]
    if layout == "between":  # in the notch of two spheres, 45° off each side
        radius, off = 0.5, (gap + 0.5) * math.sqrt(0.5)
        return [
            sc.Obstacle(sc.Sphere(radius), [gx + off, GOAL[1] + side * off, GOAL[2]])
            for side in (1.0, -1.0)
        ]
    if layout == "doorway":  # pillars 2·gap apart with the goal between them
        return [
            _wall([0.6, 0.4], gx, GOAL[1] + side * (gap + 0.2)) for side in (1.0, -1.0)
        ]
    if layout == "behind_wall":  # across the approach, the goal behind it
        return [_wall([THICKNESS, 2.0], gx - gap - THICKNESS / 2, GOAL[1])]
    if layout == "moving":  # a sphere swinging across, passing `gap` beyond
        return [
            sc.Obstacle(
                sc.Sphere(MOVING_RADIUS),
                [gx + gap + MOVING_RADIUS, GOAL[1], GOAL[2]],
                motion=Motion(
                    amplitude=[0.0, MOVING_AMPLITUDE, 0.0],
                    angular_frequency=[0.0, MOVING_FREQUENCY, 0.0],
                    phase=[0.0, -MOVING_FREQUENCY * MOVING_PASS, 0.0],
                ),
            )
        ]
    raise ValueError(f"layout = {layout!r}: must be one of {LAYOUTS}")


LAYOUTS = (
    "wall_ahead",
    "wall_beside",
    "corner",
    "sphere",
    "u_inside",
    "between",
    "doorway",
    "behind_wall",
    "moving",
)


def goal_scene(layout: str, gap: float, duration: float = 20.0) -> sc.Scenario:
    """The scene `layout` (one of LAYOUTS) with the goal `gap` metres from
    the nearest surface (for "moving", the closest the sphere passes)."""
    return sc.Scenario(
        name=f"goal_{layout}_{gap:g}",
        start=list(START),
        goal=list(GOAL),
        duration=duration,
        obstacles=_obstacles(layout, gap),
    )


def without_terminal_approach(scenario: sc.Scenario) -> sc.Scenario:
    """`scenario` with the terminal approach of mfi, apf and gf off: how
    they flew before it (mfi-paper never has it)."""
    return dataclasses.replace(
        scenario,
        navigator=dataclasses.replace(scenario.navigator, terminal_approach=False),
        apf=dataclasses.replace(scenario.apf, terminal_approach=False),
        gf=dataclasses.replace(scenario.gf, terminal_approach=False),
    )
