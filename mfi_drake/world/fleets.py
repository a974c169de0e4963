"""Scenes of N vehicles (docs/fleets.md): antipodal
circles, random start and goal pairs among a sweep's random obstacles, and
crossing streams. Each returns a `Scenario` whose first vehicle is its own
and the rest `other_vehicles`; `world.validation` checks it like any
scenario (starts apart, goals apart, both clear of obstacles)."""

import math
from dataclasses import replace

import numpy as np

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import OtherVehicle
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.world import generator
from mfi_drake.world.obstacles import obstacle_distances

CIRCLE_SPACING = 2.0  # [m] least arc between neighbours on an antipodal circle
CIRCLE_RADIUS = 6.0  # [m] the smallest antipodal circle
CIRCLE_SECONDS_PER_METRE = 5.0  # [s] an antipodal circle's duration per m of diameter
FLEET_STREAM = 3  # the random stream of random_pairs
PAIR_GAP = 1.0  # [m] least distance between two starts, and between two goals


def with_vehicles(scenario: sc.Scenario, ends: list[tuple]) -> sc.Scenario:
    """`scenario` flown by one vehicle per (start, goal) of `ends`: the first
    is the scenario's own, the rest its `other_vehicles`."""
    (start, goal), rest = ends[0], ends[1:]
    return replace(
        scenario,
        start=list(start),
        goal=list(goal),
        other_vehicles=[OtherVehicle(list(s), list(g)) for s, g in rest],
    )


def circle_radius(n: int) -> float:
    """The antipodal circle of n vehicles: CIRCLE_RADIUS, or larger where
    neighbours would be closer than CIRCLE_SPACING along it."""
    return max(CIRCLE_RADIUS, n * CIRCLE_SPACING / (2.0 * math.pi))


def antipodal_circle(
    n: int,
    radius: float | None = None,
    height: float = 2.0,
    duration: float | None = None,
) -> sc.Scenario:
    """n vehicles evenly on a horizontal circle (default `circle_radius`),
    each flying to the point opposite its start: all meet in the middle.
    Default duration: CIRCLE_SECONDS_PER_METRE per metre of diameter."""
    radius = circle_radius(n) if radius is None else radius
    if duration is None:
        duration = CIRCLE_SECONDS_PER_METRE * 2.0 * radius
    ends = []
    for k in range(n):
        a = 2.0 * math.pi * k / n
        c, s = radius * math.cos(a), radius * math.sin(a)
        ends.append(([c, s, height], [-c, -s, height]))
    scenario = sc.Scenario(name=f"antipodal_{n}", duration=duration)
    return with_vehicles(scenario, ends)


def crossing_streams(
    n: int, length: float = 12.0, spacing: float = 1.5, height: float = 2.0
) -> sc.Scenario:
    """Two streams crossing at right angles over the origin: ⌈n/2⌉ vehicles
    abreast flying along +x, the rest along +y, each stream `spacing` apart
    and `length` long."""
    ends = []
    for k in range(n):
        stream, j = k % 2, k // 2
        across = (j - (math.ceil(n / 2) if stream == 0 else n // 2) / 2 + 0.5) * spacing
        a, b = [-length / 2, across, height], [length / 2, across, height]
        if stream == 1:
            a, b = [across, -length / 2, height], [across, length / 2, height]
        ends.append((a, b))
    scenario = sc.Scenario(name=f"crossing_{n}", duration=generator.DEFAULT_DURATION)
    return with_vehicles(scenario, ends)


def random_pairs(
    field: sc.Scenario, n: int, seed: int, index: int, gap: float = PAIR_GAP
) -> sc.Scenario:
    """A sweep's random `field` (`generator.random_field`, its own start and
    goal ignored) flown by n vehicles: each starts on one end plane of the
    workspace (x = 0 or x = length, alternately, so that half of them meet
    the rest head-on) at a random point of its cross-section and flies to a
    random point of the other end. Points are drawn from the field's own
    random stream FLEET_STREAM and redrawn until they are `gap` from every
    start (goal) drawn before and clear of the obstacles by the vehicle's
    collision radius plus the workspace's clearance."""
    workspace = generator.DEFAULT_WORKSPACE
    needed = as_vehicle(field.vehicle).collision_radius + workspace.clearance
    w, h = workspace.half_width, workspace.height
    rng = np.random.default_rng([seed, index, FLEET_STREAM])
    starts, goals = [], []

    def draw(x: float, taken: list) -> list[float]:
        while True:
            y, z = rng.uniform([-w, h - w], [w, h + w])
            p = [x, float(y), float(z)]
            apart = all(math.dist(p, q) >= gap for q in taken)
            if apart and obstacle_distances(field, [p])[0] >= needed:
                return p

    for k in range(n):
        there, back = (0.0, workspace.length)[:: 1 if k % 2 == 0 else -1]
        starts.append(draw(there, starts))
        goals.append(draw(back, goals))
    return with_vehicles(field, list(zip(starts, goals, strict=True)))
