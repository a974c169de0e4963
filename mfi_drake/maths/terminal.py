"""The terminal approach (repair (i), docs/goals.md): an obstacle's terms
faded near a goal that lies beside it, for the shipped methods
(`fields.superposed` weighs each obstacle by `terminal_weight`) and for a
user's field (`with_terminal_approach`)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from mfi_drake.maths.so3 import TINY, dot, entries, norm
from mfi_drake.maths.triples import _ramp

# Repair (i)'s tolerance [m]: how far behind an obstacle's tangent plane at the
# closest point the goal may lie and still have the obstacle's terms faded
# near it (round a curved obstacle the plane at the vehicle's closest point
# leaves a goal beside it a little behind; see `terminal_weight`).
TERMINAL_SLACK = 0.05


def terminal_weight(r_o: np.ndarray, r_g: np.ndarray, collision_radius: float, params):
    """The factor (0 to 1) on an obstacle's terms of the terminal approach
    (repair (i); the baselines' `terminal_approach`): 1 where it is off.

    Near a goal that lies near a surface, the obstacle terms hold the vehicle
    short of it (eq 14's f_a ∝ r⁻³ against eq 20's K_P |r_g|). Ge & Cui
    ("New potential functions for mobile robot path planning", IEEE T-RA
    16(5), 2000) multiply the repulsion by a power of the goal distance ρ_g
    so that it vanishes at the goal. Here the factor is a smoothstep of ρ_g,
    0 within Z/2 and 1 beyond Z (Z = `params.terminal_zone`, where the goal
    law is eq 20's PD), so nothing changes outside Z; and it acts only on an
    obstacle that does not stand between the vehicle and the goal: the
    tangent plane at its closest point q separates a convex obstacle from
    the vehicle, so when the goal lies on the vehicle's side of it,
    g = (q − p_g)·n − ρ ≥ 0, the straight PD approach stays clear of it.
    The weight of the fade rises from 0 at g = −TERMINAL_SLACK to 1 at
    g = 0 and falls back to 0 as g grows from R/2 to R (R =
    `params.terminal_reach`, the obstacle terms' range): a goal farther
    from the obstacle than its range needs no fade. A scalar factor keeps
    each term's direction: eq 12's and eq 14's F stay ⟂ v (zero work), GF's
    S ṗ stays gyroscopic."""
    if not getattr(params, "terminal_approach", False):
        return 1.0
    zone, reach = params.terminal_zone, params.terminal_reach
    r_o, r_g = entries(r_o), entries(r_g)
    to_goal = norm(r_g)
    distance = norm(r_o)
    if to_goal >= zone or distance < TINY:
        return 1.0
    g = distance - dot(r_g, r_o) / distance - collision_radius
    weight = _ramp(g, -TERMINAL_SLACK, 0.0)
    if reach < math.inf:
        weight = weight * _ramp(g, reach, 0.5 * reach)
    x = _ramp(to_goal, 0.5 * zone, zone)
    return 1.0 - weight * (1.0 - x * x * (3.0 - 2.0 * x))


@dataclass(frozen=True)
class TerminalApproach:
    """The terminal approach of `with_terminal_approach` (the attributes
    `terminal_weight` reads from a method's parameters)."""

    terminal_zone: float = 1.0  # m, Z: the obstacle terms fade within it
    terminal_reach: float = math.inf  # m, R: goals this far from a plane keep it
    terminal_approach: bool = True


def with_terminal_approach(
    field, collision_radius: float, approach: TerminalApproach = TerminalApproach()
):
    """A user's navigation field `field(position, velocity, obstacle_points,
    goal, **gains)` (see `systems.user_field.UserFieldNavigator`) with the
    terminal approach of `terminal_weight` (docs/goals.md): each obstacle's
    part, field(.., [r_o], ..) − field(.., [], ..), is weighed by
    `terminal_weight`. Exact for a field that sums an attraction and one term
    per obstacle (the README's example); k + 1 calls of `field` for k
    readings. The default reach is unbounded, as a 1/r² repulsion is; the
    zone should be where the field's attraction is a PD (1 m for a pull
    K_P r_g saturated at |r_g| = 1 m)."""

    @functools.wraps(field)
    def wrapped(position, velocity, obstacle_points, goal, **gains):
        points = np.asarray(obstacle_points, float).reshape(-1, 3)
        free = np.asarray(field(position, velocity, points[:0], goal, **gains), float)
        force = free.copy()
        r_g = np.asarray(goal, float) - np.asarray(position, float)
        for r_o in points:
            alone = np.asarray(field(position, velocity, r_o[None], goal, **gains))
            w = terminal_weight(r_o, r_g, collision_radius, approach)
            force = force + w * (alone - free)
        return force

    return wrapped
