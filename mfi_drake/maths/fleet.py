"""A fleet's whole chain in one call: for every vehicle, its readings of the
others, the relative obstacle field (eq 11–15, or a baseline's), eq 21's
goal terms (eq 16–20, or the baselines' attraction), or a user's field's
F_n (`user_forces`), the attitude PD (eq 22–25) and the mixer (eq 8),
composed of the
functions the single-vehicle systems call, in the order they call them
(docs/fleets.md, "One integrator"). Plain Python, so it runs as it is;
`maths.compiled` compiles it for `systems.fleet.FleetChain`.
"""

import math

import numpy as np

from mfi_drake.maths.escape_steering import escape_terms, relative_escape_terms
from mfi_drake.maths.fields import MODE_CRUISE, next_mode, superposed
from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    POSITION,
    STATE_SIZE,
    VELOCITY,
    reading_count,
    seen_points,
    signal_size,
    slices,
)
from mfi_drake.maths.motion import relative_field, vehicle_readings
from mfi_drake.maths.quadcopter import attitude_command, mix


def row_layout(readings: int = OBSTACLE_COUNT) -> tuple[tuple[str, int], ...]:
    """A vehicle's row of `fleet_chain` for a sensor of `readings` readings:
    what the single-vehicle diagram logs, in its order
    (`flight.chain.log_layout`)."""
    return (
        ("state", STATE_SIZE),
        ("obstacle", signal_size(readings)),
        ("obstacle_force_terms", 6),
        ("goal_force_terms", 9),
        ("navigation_force", 3),
        ("mode", 1),
        ("attitude_setpoint", 4),
        ("propeller_force", 4),
        ("saturation", 1),
    )


def row_size(readings: int = OBSTACLE_COUNT) -> int:
    """The length of a row of `row_layout(readings)`."""
    return sum(size for _, size in row_layout(readings))


def row_slices(readings: int = OBSTACLE_COUNT) -> dict[str, slice]:
    """Where each entry of `row_layout(readings)` lies in a row."""
    return slices(row_layout(readings))


ROW = row_layout()  # at the default count
ROW_SIZE = row_size()


def fleet_chain(
    field,
    states: np.ndarray,
    scene: np.ndarray,
    scene_velocities: np.ndarray,
    moving: bool,
    modes: np.ndarray,
    goals: np.ndarray,
    params,
    attract,
    vehicle,
    attitude,
    K_P: np.ndarray,
    K_D: np.ndarray,
    D_inv: np.ndarray,
    radius: float,
    reach: float,
    keep_right: float,
    own_pace: bool,
    blend_speed: float,
    memories: np.ndarray,
    rule,
    rate: float,
    ground: float,
    forces: np.ndarray,
    rows: np.ndarray,
) -> None:
    """Fills `rows` (N, `row_size`) with each vehicle's row at the fleet's
    `states` (N, 12) under the obstacle field `field` of parameters
    `params` (`fields.obstacle_field` or a baseline's, or its compiled
    form). Vehicle k sees the scene's readings `scene[k]` and the others'
    collision spheres (radius `radius`, within the sensor's `reach`;
    `vehicle_readings`), flies toward `goals[k]` with the goal part
    `attract` of `params` (`fields.goal_terms`, eq 21 in `modes[k]`, or
    the baselines' `attraction_terms`).
    `vehicle`, `attitude`: the vehicle and the attitude PD's parameters (the
    scenario's `navigator`, every method's); parameters are
    `compiled.record`s for the compiled form. K_P, K_D: eq 25's gains;
    D_inv: eq 8 inverted; keep_right, own_pace, blend_speed: the relative
    field's (`relative_field`). A lone vehicle
    (N = 1) reads the static scene with its own velocity, as the
    single-vehicle navigator does (`superposed`; `flight.chain.navigator_of`
    takes the relative field only where something else moves). `rule`:
    the escape rule's parameters (mfi; None: none), which aims the
    field at the subgoal of vehicle k's memory `memories[k]`, read with
    the corner gain `rate` above the ground at height `ground` from the
    scene's readings `scene[k]` alone (`escape_steering.escape_terms`, in a fleet
    `escape_steering.relative_escape_terms`: the others are the field's).
    `forces` (N, 3): a user's field's F_n of each vehicle (`user_forces`),
    flown as `PassThroughGoal` hands it on (`attract` is `no_goal_terms`);
    (0, 3): the method's field."""
    # Over 80 lines: the loop's branches are the ways a vehicle reads its
    # obstacles (a user's field, alone, alone among moving obstacles, in a
    # fleet; each with or without the escape rule), all over the same two
    # dozen arguments: apart, each would take them all again.
    centres, velocities = states[:, POSITION], states[:, VELOCITY]
    for k in range(len(states)):
        x, mode, goal = states[k], modes[k], goals[k]
        p, v = x[POSITION], x[VELOCITY]
        if len(forces):  # a user's field: its F_n as the obstacle force
            obstacle = readings_of(k, states, scene, scene_velocities, radius, reach)
            F_o, terms = forces[k], np.concatenate((forces[k], np.zeros(3)))
        elif len(states) == 1:  # alone: the scene's field alone
            obstacle = scene[k]
            if moving:  # the velocity relative to each reading's obstacle
                F_o, terms = relative_field(
                    field,
                    x,
                    obstacle,
                    scene_velocities[k],
                    np.zeros(reading_count(obstacle)),  # no vehicle
                    goal,
                    radius,
                    params,
                    own_pace,
                    blend_speed,
                )
            elif rule is None:
                A, B = superposed(field, v, obstacle, goal - p, radius, params)
                F_o, terms = A + B, np.concatenate((A, B))
            else:  # mfi: MFI's field aimed at the escape rule's subgoal
                A, B, _ = escape_terms(
                    field,
                    memories[k],
                    p,
                    v,
                    obstacle,
                    obstacle,
                    goal,
                    radius,
                    params,
                    rule,
                    rate,
                    ground,
                    mode == MODE_CRUISE,
                )
                F_o, terms = A + B, np.concatenate((A, B))
        else:
            obstacle, u, flags = vehicle_readings(
                p, scene[k], scene_velocities[k], centres, velocities, radius, reach, k
            )
            if rule is None:
                F_o, terms = relative_field(
                    field,
                    x,
                    obstacle,
                    u,
                    keep_right * flags,
                    goal,
                    radius,
                    params,
                    own_pace,
                    blend_speed,
                )
            else:  # mfi: the memory reads the scene, the field every reading
                F_o, terms, _ = relative_escape_terms(
                    field,
                    memories[k],
                    x,
                    scene[k],
                    obstacle,
                    u,
                    keep_right * flags,
                    goal,
                    radius,
                    params,
                    rule,
                    rate,
                    ground,
                    own_pace,
                    blend_speed,
                    mode == MODE_CRUISE,
                )
        F_gc, F_v, F_pd = attract(mode, p, v, goal, params, F_o, vehicle.mass)
        F_n = F_o + F_gc + F_v + F_pd
        thrust_torque, setpoint = attitude_command(x, F_n, vehicle, attitude, K_P, K_D)
        u_rotor, saturated = mix(thrust_torque, D_inv, vehicle.u_max)
        # The row in `row_layout`'s order.
        row, at = rows[k], 0
        for part in (x, obstacle, terms, F_gc, F_v, F_pd, F_n):
            at = _put(row, at, part)
        row[at] = mode
        at = _put(row, at + 1, setpoint)
        at = _put(row, at, u_rotor)
        row[at] = saturated


def readings_of(
    k: int,
    states: np.ndarray,
    scene: np.ndarray,
    scene_velocities: np.ndarray,
    radius: float,
    reach: float,
) -> np.ndarray:
    """Vehicle k's readings: the scene's alone, or in a fleet the scene's and
    the others' (`vehicle_readings`)."""
    if len(states) == 1:
        return scene[k]
    x = states[k]
    return vehicle_readings(
        x[POSITION],
        scene[k],
        scene_velocities[k],
        states[:, POSITION],
        states[:, VELOCITY],
        radius,
        reach,
        k,
    )[0]


def fleet_readings(
    states: np.ndarray,
    scene: np.ndarray,
    scene_velocities: np.ndarray,
    radius: float,
    reach: float,
    out: np.ndarray,
) -> None:
    """Fills `out` (N, 4 readings) with each vehicle's readings
    (`readings_of`)."""
    for k in range(len(states)):
        out[k] = readings_of(k, states, scene, scene_velocities, radius, reach)


def user_forces(
    user,
    states: np.ndarray,
    readings: np.ndarray,
    goals: np.ndarray,
    gains: tuple,
    forces: np.ndarray,
) -> int:
    """Fills `forces` (N, 3) with each vehicle's F_n of a user's field
    `user(position, velocity, obstacle_points, goal, gains)` (its keyword
    gains bound by position, `compiled.user_field`), called with copies
    (`UserFieldNavigator`'s contract) at vehicle k's `readings[k]`
    (`fleet_readings`). Returns the first vehicle whose F_n is not 3
    finite numbers (the rest unfilled), or −1. Small on purpose: it is
    compiled for each user's field in each process."""
    for k in range(len(states)):
        x = states[k]
        force = user(
            x[POSITION].copy(),
            x[VELOCITY].copy(),
            seen_points(readings[k]),
            goals[k].copy(),
            gains,
        )
        if force.size != 3:
            return k
        for i in range(3):  # math's, not numpy's ufunc: compiled in no time
            if not math.isfinite(force[i]):
                return k
            forces[k, i] = force[i]
    return -1


def no_goal_terms(mode, p, v, goal, params, F_o, mass) -> tuple:
    """The goal terms (F_gc, F_v, F_pd) of a method whose navigator gives
    F_n (a user's field, `PassThroughGoal`): none."""
    return np.zeros(3), np.zeros(3), np.zeros(3)


def _put(row: np.ndarray, at: int, part: np.ndarray) -> int:
    """Writes `part` into `row` from `at`; where the next part goes."""
    row[at : at + len(part)] = part
    return at + len(part)


def fleet_modes(
    states: np.ndarray, goals: np.ndarray, modes: np.ndarray, params, out: np.ndarray
) -> None:
    """Fills `out` with the mode eq 21 selects for each vehicle from
    `modes` at `states` (`fields.next_mode`)."""
    for k in range(len(states)):
        x = states[k]
        out[k] = next_mode(modes[k], x[POSITION], x[VELOCITY], goals[k], params)
