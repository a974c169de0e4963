"""Navigating among moving obstacles with the velocity relative to each
obstacle (docs/dynamic.md).

The paper's fields are written with the vehicle's velocity v. Among moving
obstacles the natural generalisation is, per obstacle, the velocity relative
to it, v − u. The sensor measures positions only, so u is estimated from
successive readings (`ObstacleVelocityEstimator`, the normal velocity of
`maths.motion`), and the method's own obstacle field is evaluated once per
reading, given that reading alone and v − u of its obstacle
(`RelativeNavigator`); the terms add, as the fields of separate obstacles
do:

    state, obstacle ──▶ ObstacleVelocityEstimator ──obstacle_velocity──┐
    state, obstacle ──▶ RelativeNavigator ◀────────────────────────────┘
                            └──▶ obstacle_force, obstacle_force_terms

`relative_navigator` builds that as one diagram with the ports of a
navigator ("state", "obstacle" → "obstacle_force", "obstacle_force_terms"),
plus "obstacle_velocity" for the log.
"""

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Diagram, DiagramBuilder, LeafSystem

from mfi_drake.config.dynamic import RelativeVelocity
from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    POSITION,
    STATE_SIZE,
    readings,
    signal_size,
)
from mfi_drake.maths.motion import (
    PACE_BLEND_SPEED,
    along_normal,
    match_points,
    normal_velocity,
    relative_field,
)
from mfi_drake.systems.last_result import LastResult

VELOCITY_SIGNAL_SIZE = 3 * OBSTACLE_COUNT  # u of each reading, default count


@dataclass(frozen=True)
class Tracks:
    """The closest points of the last sample (world frame) and the
    estimated velocity of each one's obstacle; `estimated` is False for a
    point seen once."""

    points: np.ndarray  # (m, 3)
    velocities: np.ndarray  # (m, 3)
    estimated: tuple[bool, ...]

    @staticmethod
    def empty() -> "Tracks":
        return Tracks(np.zeros((0, 3)), np.zeros((0, 3)), ())


def _seen(x: np.ndarray, obstacle: np.ndarray) -> tuple[list, np.ndarray]:
    """(the r_o of the seen readings with their slots, their world points)."""
    seen = [(i, r_o) for i, (r_o, s) in enumerate(readings(obstacle)) if s > 0.5]
    points = np.array([x[POSITION] + r_o for _, r_o in seen]).reshape(-1, 3)
    return seen, points


class ObstacleVelocityEstimator(LeafSystem):
    """Each reading's obstacle velocity u, estimated from successive readings.

    .. pydrake_system::

        name: ObstacleVelocityEstimator
        input_ports:
        - state
        - obstacle
        output_ports:
        - obstacle_velocity

    "state": the state the controller reads (12); "obstacle": the readings of
    `maths.layout`; "obstacle_velocity": `readings` 3-vectors u, one per
    reading (zero where nothing is seen or nothing is known yet).

    Every h = 1/rate_hz s from t = 0, each seen reading's closest point
    q = p + r_o is matched to the last sample's nearest one within `gate`
    (`maths.motion.match_points`); a matched point gives the normal velocity
    n (n·Δq)/h, low-passed with time constant τ (its first estimate taken
    as it is); an unmatched one starts a track with no estimate. The tracks
    are abstract state. The output matches the current readings to the
    tracks the same way and gives each the component of its track's u along
    its own normal.
    """

    def __init__(
        self,
        rate_hz: float,
        time_constant: float,
        gate: float,
        readings: int = OBSTACLE_COUNT,
    ):
        super().__init__()
        self._count = int(readings)
        self._h = 1.0 / float(rate_hz)
        self._alpha = self._h / (float(time_constant) + self._h)
        self._gate = float(gate)
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self._obstacle = self.DeclareVectorInputPort(
            "obstacle", signal_size(self._count)
        )
        self._tracks = self.DeclareAbstractState(AbstractValue.Make(Tracks.empty()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._h, 0.0, self._sample)
        self.DeclareVectorOutputPort(
            "obstacle_velocity",
            3 * self._count,
            self._calc,
            prerequisites_of_calc={
                self._state.ticket(),
                self._obstacle.ticket(),
                self.abstract_state_ticket(self._tracks),
            },
        )

    def tracks(self, context) -> Tracks:
        return context.get_abstract_state(self._tracks).get_value()

    def _sample(self, context, state):
        before = self.tracks(context)
        seen, points = _seen(self._state.Eval(context), self._obstacle.Eval(context))
        matched = match_points(points, before.points, self._gate)
        velocities, estimated = np.zeros_like(points), []
        for k, ((_, r_o), j) in enumerate(zip(seen, matched, strict=True)):
            if j is not None:
                raw = normal_velocity(r_o, points[k] - before.points[j], self._h)
                last = before.velocities[j]
                velocities[k] = (
                    last + self._alpha * (raw - last) if before.estimated[j] else raw
                )
            estimated.append(j is not None)
        state.get_mutable_abstract_state(self._tracks).set_value(
            Tracks(points, velocities, tuple(estimated))
        )

    def _calc(self, context, output):
        tracks = self.tracks(context)
        seen, points = _seen(self._state.Eval(context), self._obstacle.Eval(context))
        u = np.zeros((self._count, 3))
        for (slot, r_o), j in zip(
            seen, match_points(points, tracks.points, self._gate), strict=True
        ):
            if j is not None and tracks.estimated[j]:
                u[slot] = along_normal(r_o, tracks.velocities[j])
        output.SetFromVector(u.ravel())


class RelativeNavigator(LeafSystem):
    """An obstacle navigator's field summed over the readings, each reading's
    term computed alone with the velocity relative to its obstacle, v − u_i,
    and with `own_pace` given the pace of the field computed with v itself
    (`maths.motion.keep_own_pace`, for the force and each of its terms).

    .. pydrake_system::

        name: RelativeNavigator
        input_ports:
        - state
        - obstacle
        - obstacle_velocity
        output_ports:
        - obstacle_force
        - obstacle_force_terms

    `navigator`: an `ObstacleNavigator` of its own (not in a diagram), whose
    field, goal, collision radius and parameters it evaluates
    (`maths.motion.relative_field`, which a fleet on one integrator
    evaluates too); its force must be the sum of its readings'. One system
    rather than a navigator per reading and adders: the same sums in the
    same order, with a fifth of the ports to evaluate.

    `keep_right` > 0 (degrees) adds the input "vehicle_readings" (1 where a
    reading is another vehicle, `OtherVehicleReadings`) and the rule of the
    road: a vehicle reading's relative velocity is turned that far right
    about e_z (`maths.motion.turned_right`) before its term is evaluated.
    `readings`: how many readings the "obstacle" input holds.
    """

    def __init__(
        self,
        navigator,
        own_pace: bool,
        blend_speed: float,
        keep_right: float = 0.0,
        readings: int = OBSTACLE_COUNT,
    ):
        super().__init__()
        count = int(readings)
        self._navigator = navigator
        self._own_pace = bool(own_pace)
        self._blend = float(blend_speed)
        self._keep_right = float(keep_right)
        self._last = LastResult()
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self._obstacle = self.DeclareVectorInputPort("obstacle", signal_size(count))
        self._velocity = self.DeclareVectorInputPort("obstacle_velocity", 3 * count)
        self._no_turns = np.zeros(count)
        tickets = {port.ticket() for port in (self._state, self._obstacle)}
        tickets.add(self._velocity.ticket())
        self._vehicles = None
        if self._keep_right > 0.0:
            self._vehicles = self.DeclareVectorInputPort("vehicle_readings", count)
            tickets.add(self._vehicles.ticket())
        for k, (name, size) in enumerate(
            (("obstacle_force", 3), ("obstacle_force_terms", 6))
        ):
            self.DeclareVectorOutputPort(
                name,
                size,
                lambda context, out, k=k: out.SetFromVector(self._forces(context)[k]),
                prerequisites_of_calc=tickets,
            )

    def _forces(self, context):
        """(F_o, its terms [A, B]), computed once for both outputs."""
        x = self._state.Eval(context)
        obstacle = self._obstacle.Eval(context)
        u = self._velocity.Eval(context)
        turns = self._no_turns
        if self._vehicles is not None:
            turns = self._keep_right * self._vehicles.Eval(context)
        key = x.tobytes() + obstacle.tobytes() + u.tobytes() + turns.tobytes()
        return self._last(key, self._forces_of, x, obstacle, u, turns)

    def _forces_of(self, x, obstacle, u, turns):
        navigator = self._navigator
        return relative_field(
            navigator.field,
            x,
            obstacle,
            u,
            turns,
            navigator.goal,
            navigator.collision_radius,
            navigator.params,
            self._own_pace,
            self._blend,
        )


def relative_navigator(
    make_navigator: Callable[[], LeafSystem],
    estimate: RelativeVelocity,
    rate_hz: float,
    keep_right: float = 0.0,
    readings: int = OBSTACLE_COUNT,
) -> Diagram:
    """A navigator that sums `make_navigator()`'s field over the readings,
    each with the velocity relative to its obstacle, estimated from readings
    sampled at `rate_hz` (see the module docstring), and with
    `estimate.own_pace` keeps the pace of that field computed with the
    vehicle's own velocity. `make_navigator()` must be an
    `ObstacleNavigator`, whose force is the sum of its readings'.
    `keep_right` > 0: `RelativeNavigator`'s rule of the road, its input
    "vehicle_readings" exported. `readings`: the sensor's count."""
    builder = DiagramBuilder()
    estimator = builder.AddNamedSystem(
        "velocity_estimator",
        ObstacleVelocityEstimator(
            rate_hz, estimate.time_constant, estimate.gate, readings
        ),
    )
    navigator = builder.AddNamedSystem(
        "relative_navigator",
        RelativeNavigator(
            make_navigator(), estimate.own_pace, PACE_BLEND_SPEED, keep_right, readings
        ),
    )
    for name in ("state", "obstacle"):
        builder.ExportInput(estimator.GetInputPort(name), name)
        builder.ConnectInput(name, navigator.GetInputPort(name))
    if navigator.HasInputPort("vehicle_readings"):
        builder.ExportInput(
            navigator.GetInputPort("vehicle_readings"), "vehicle_readings"
        )
    velocity = estimator.GetOutputPort("obstacle_velocity")
    builder.Connect(velocity, navigator.GetInputPort("obstacle_velocity"))
    for name in ("obstacle_force", "obstacle_force_terms"):
        builder.ExportOutput(navigator.GetOutputPort(name), name)
    builder.ExportOutput(velocity, "obstacle_velocity")
    return builder.Build()
