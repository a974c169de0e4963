"""Navigating among moving obstacles with the velocity relative to each
obstacle (docs/dynamic.md).

The paper's fields are written with the vehicle's velocity v. Among moving
obstacles the natural generalisation is, per obstacle, the velocity relative
to it, v − u. The sensor measures positions only, so u is estimated from
successive readings (`ObstacleVelocityEstimator`, the normal velocity of
`maths.motion`), and the method's own navigator is flown once per reading,
each copy given one reading and v − u of its obstacle (`RelativeReadings`);
their forces add, as the fields of separate obstacles do:

    state, obstacle ──▶ ObstacleVelocityEstimator ──obstacle_velocity──┐
    state, obstacle ──▶ RelativeReadings ◀─────────────────────────────┘
                            │ state_i, obstacle_i (i < OBSTACLE_COUNT)
                            ▼
                       navigator_i ──▶ Adders ──▶ obstacle_force(_terms)

`relative_navigator` builds that as one diagram with the ports of a
navigator ("state", "obstacle" → "obstacle_force", "obstacle_force_terms"),
plus "obstacle_velocity" for the log.
"""

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Diagram, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import Adder

from mfi_drake.config.dynamic import RelativeVelocity
from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    OBSTACLE_SIGNAL_SIZE,
    POSITION,
    STATE_SIZE,
    VELOCITY,
    obstacle_signal,
    readings,
)
from mfi_drake.maths.motion import (
    PACE_BLEND_SPEED,
    along_normal,
    keep_own_pace,
    match_points,
    normal_velocity,
)

VELOCITY_SIGNAL_SIZE = 3 * OBSTACLE_COUNT  # u of each reading, nearest first


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
    `maths.layout`; "obstacle_velocity": OBSTACLE_COUNT 3-vectors u, one per
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

    def __init__(self, rate_hz: float, time_constant: float, gate: float):
        super().__init__()
        self._h = 1.0 / float(rate_hz)
        self._alpha = self._h / (float(time_constant) + self._h)
        self._gate = float(gate)
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self._obstacle = self.DeclareVectorInputPort("obstacle", OBSTACLE_SIGNAL_SIZE)
        self._tracks = self.DeclareAbstractState(AbstractValue.Make(Tracks.empty()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._h, 0.0, self._sample)
        self.DeclareVectorOutputPort(
            "obstacle_velocity",
            VELOCITY_SIGNAL_SIZE,
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
        u = np.zeros((OBSTACLE_COUNT, 3))
        for (slot, r_o), j in zip(
            seen, match_points(points, tracks.points, self._gate), strict=True
        ):
            if j is not None and tracks.estimated[j]:
                u[slot] = along_normal(r_o, tracks.velocities[j])
        output.SetFromVector(u.ravel())


class RelativeReadings(LeafSystem):
    """One navigator input pair per reading: the reading alone, and the state
    with the velocity relative to that reading's obstacle.

    .. pydrake_system::

        name: RelativeReadings
        input_ports:
        - state
        - obstacle
        - obstacle_velocity
        output_ports:
        - state_0
        - obstacle_0
        - ...

    "state_i": the state with v − u_i; "obstacle_i": reading i as the only
    reading ("nothing seen" when reading i is not).
    """

    def __init__(self):
        super().__init__()
        state = self.DeclareVectorInputPort("state", STATE_SIZE)
        obstacle = self.DeclareVectorInputPort("obstacle", OBSTACLE_SIGNAL_SIZE)
        velocity = self.DeclareVectorInputPort(
            "obstacle_velocity", VELOCITY_SIGNAL_SIZE
        )
        for i in range(OBSTACLE_COUNT):
            self.DeclareVectorOutputPort(
                f"state_{i}",
                STATE_SIZE,
                lambda context, out, i=i: out.SetFromVector(
                    _relative(state.Eval(context), velocity.Eval(context), i)
                ),
                prerequisites_of_calc={state.ticket(), velocity.ticket()},
            )
            self.DeclareVectorOutputPort(
                f"obstacle_{i}",
                OBSTACLE_SIGNAL_SIZE,
                lambda context, out, i=i: out.SetFromVector(
                    _alone(obstacle.Eval(context), i)
                ),
                prerequisites_of_calc={obstacle.ticket()},
            )


def _relative(x: np.ndarray, u: np.ndarray, i: int) -> np.ndarray:
    relative = x.copy()
    relative[VELOCITY] -= u[3 * i : 3 * i + 3]
    return relative


def _alone(obstacle: np.ndarray, i: int) -> np.ndarray:
    r_o, seen = readings(obstacle)[i]
    return obstacle_signal([r_o] if seen > 0.5 else [])


class OwnPace(LeafSystem):
    """The relative navigators' force, steering as they do but keeping the
    pace of the navigator flown with the vehicle's own velocity
    (`maths.motion.keep_own_pace`), for the force and each of its two terms.

    .. pydrake_system::

        name: OwnPace
        input_ports:
        - state
        - relative_force
        - relative_terms
        - own_force
        - own_terms
        output_ports:
        - obstacle_force
        - obstacle_force_terms
    """

    def __init__(self, blend_speed: float = PACE_BLEND_SPEED):
        super().__init__()
        self._blend = float(blend_speed)
        state = self.DeclareVectorInputPort("state", STATE_SIZE)
        for output, size in (("obstacle_force", 3), ("obstacle_force_terms", 6)):
            kind = "force" if size == 3 else "terms"
            relative = self.DeclareVectorInputPort(f"relative_{kind}", size)
            own = self.DeclareVectorInputPort(f"own_{kind}", size)
            self.DeclareVectorOutputPort(
                output,
                size,
                lambda context, out, relative=relative, own=own: out.SetFromVector(
                    self._paced(
                        state.Eval(context), relative.Eval(context), own.Eval(context)
                    )
                ),
                prerequisites_of_calc={state.ticket(), relative.ticket(), own.ticket()},
            )

    def _paced(self, x, relative, own):
        """Each 3-vector of `relative` with the pace of `own`'s."""
        v = x[VELOCITY]
        return np.concatenate(
            [
                keep_own_pace(relative[k : k + 3], own[k : k + 3], v, self._blend)
                for k in range(0, len(relative), 3)
            ]
        )


def relative_navigator(
    make_navigator: Callable[[], LeafSystem], estimate: RelativeVelocity, rate_hz: float
) -> Diagram:
    """A navigator that sums `make_navigator()`'s fields over the readings,
    each with the velocity relative to its obstacle, estimated from readings
    sampled at `rate_hz` (see the module docstring), and with
    `estimate.own_pace` keeps the pace of `make_navigator()` flown with the
    vehicle's own velocity (`OwnPace`). The navigator must be one whose force
    is the sum of its readings' (`ObstacleNavigator`)."""
    builder = DiagramBuilder()
    estimator = builder.AddNamedSystem(
        "velocity_estimator",
        ObstacleVelocityEstimator(rate_hz, estimate.time_constant, estimate.gate),
    )
    split = builder.AddNamedSystem("readings", RelativeReadings())
    for name in ("state", "obstacle"):
        builder.ExportInput(estimator.GetInputPort(name), name)
        builder.ConnectInput(name, split.GetInputPort(name))
    builder.Connect(
        estimator.GetOutputPort("obstacle_velocity"),
        split.GetInputPort("obstacle_velocity"),
    )
    pace = None
    if estimate.own_pace:
        pace = builder.AddNamedSystem("own_pace", OwnPace())
        own = builder.AddNamedSystem("navigator_own", make_navigator())
        for name in ("state", "obstacle"):
            builder.ConnectInput(name, own.GetInputPort(name))
        builder.ConnectInput("state", pace.GetInputPort("state"))
    for output, size in (("obstacle_force", 3), ("obstacle_force_terms", 6)):
        adder = builder.AddNamedSystem(f"{output}_sum", Adder(OBSTACLE_COUNT, size))
        if pace is None:
            builder.ExportOutput(adder.get_output_port(), output)
            continue
        kind = "force" if size == 3 else "terms"
        builder.Connect(adder.get_output_port(), pace.GetInputPort(f"relative_{kind}"))
        builder.Connect(own.GetOutputPort(output), pace.GetInputPort(f"own_{kind}"))
        builder.ExportOutput(pace.GetOutputPort(output), output)
    for i in range(OBSTACLE_COUNT):
        navigator = builder.AddNamedSystem(f"navigator_{i}", make_navigator())
        for name in ("state", "obstacle"):
            builder.Connect(
                split.GetOutputPort(f"{name}_{i}"), navigator.GetInputPort(name)
            )
        for output in ("obstacle_force", "obstacle_force_terms"):
            adder = builder.GetSubsystemByName(f"{output}_sum")
            builder.Connect(navigator.GetOutputPort(output), adder.get_input_port(i))
    builder.ExportOutput(
        estimator.GetOutputPort("obstacle_velocity"), "obstacle_velocity"
    )
    return builder.Build()
