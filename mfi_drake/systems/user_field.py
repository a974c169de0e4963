"""The navigation systems of a user's own field (docs/api.md, the README's
"your own navigation field"): `UserFieldNavigator` calls the user's Python
function for F_n, and `PassThroughGoal` hands it on as the goal attraction,
so that a user's method has the same two systems and ports as the shipped
ones (`systems.navigation`). Float only: they call Python.
"""

import numpy as np
from pydrake.systems.framework import LeafSystem

from mfi_drake.maths.fields import MODE_PD
from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    STATE_SIZE,
    position_velocity,
    seen_points,
    signal_size,
)
from mfi_drake.systems.last_result import LastResult


class UserFieldError(RuntimeError):
    """A user's navigation field raised, or returned no finite 3-vector; the
    message is one line naming the function and the simulated time."""


class UserFieldNavigator(LeafSystem):
    """A user's navigation field F_n = field(position, velocity,
    obstacle_points, goal) as a navigator (float only: it calls Python).

    `field` gets the position, velocity and goal as 3-vectors [m, m/s, world
    frame, z up] and obstacle_points, a (k, 3) array of the seen readings'
    r_o, nearest first, plus `gains` as keyword arguments (the scenario's
    `field_gains`, none by default); it returns F_n [N, world frame]. Its F_n leaves as
    "obstacle_force" so that a `PassThroughGoal` hands it on unchanged.

    .. pydrake_system::

        name: UserFieldNavigator
        input_ports:
        - state
        - obstacle
        output_ports:
        - obstacle_force
        - obstacle_force_terms

    "obstacle_force_terms": [F_n, 0] (6).
    """

    def __init__(
        self,
        field,
        name: str,
        goal,
        gains: dict | None = None,
        readings: int = OBSTACLE_COUNT,
    ):
        super().__init__()
        self.field = field
        self.field_name = name
        self.goal = np.array(goal, dtype=float)
        self.gains = dict(gains or {})  # keyword arguments of every call
        self._last = LastResult()
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self._obstacle = self.DeclareVectorInputPort("obstacle", signal_size(readings))
        tickets = {self._state.ticket(), self._obstacle.ticket()}
        self.DeclareVectorOutputPort(
            "obstacle_force",
            3,
            lambda context, out: out.SetFromVector(self._force(context)),
            prerequisites_of_calc=tickets,
        )
        self.DeclareVectorOutputPort(
            "obstacle_force_terms",
            6,
            lambda context, out: out.SetFromVector(
                np.concatenate([self._force(context), np.zeros(3)])
            ),
            prerequisites_of_calc=tickets,
        )

    def _force(self, context):
        x = self._state.Eval(context)
        obstacle = self._obstacle.Eval(context)
        key = x.tobytes() + obstacle.tobytes()
        return self._last(key, self._call, x, obstacle, context.get_time())

    def _call(self, x, obstacle, time: float) -> np.ndarray:
        return call_field(
            self.field, self.field_name, self.gains, self.goal, x, obstacle, time
        )


def call_field(
    field,
    name: str,
    gains: dict,
    goal: np.ndarray,
    x: np.ndarray,
    obstacle: np.ndarray,
    time: float,
) -> np.ndarray:
    """F_n of the user's `field` (named `name`, called with its keyword
    `gains`) toward `goal` at the state `x` and the readings `obstacle` at
    `time`, as
    `UserFieldNavigator` flies it; raises UserFieldError where it raises or
    returns no finite 3-vector."""
    p, v = position_velocity(x)
    where = f"{name} at t = {time:.3f} s"
    try:
        # Copies: the user's function cannot change the diagram's values.
        force = field(p.copy(), v.copy(), seen_points(obstacle), goal.copy(), **gains)
        force = np.asarray(force, dtype=float)
    except Exception as e:
        message = " ".join(str(e).split())
        raise UserFieldError(f"{where}: raised {type(e).__name__}: {message}") from None
    if force.shape != (3,) or not np.all(np.isfinite(force)):
        shown = " ".join(repr(force.tolist()).split())[:80]
        raise UserFieldError(
            f"{where}: returned {shown}: must be 3 finite numbers (F_n [N])"
        )
    return force


class PassThroughGoal(LeafSystem):
    """The goal attraction of a method whose navigator already gives F_n (a
    user field): F_n = F_o, no goal terms, mode PD.

    .. pydrake_system::

        name: PassThroughGoal
        input_ports:
        - state
        - obstacle_force
        output_ports:
        - navigation_force
        - goal_force_terms
        - mode

    "state" is unused; it is there so that every goal attraction has the
    same ports.
    """

    def __init__(self):
        super().__init__()
        self.DeclareVectorInputPort("state", STATE_SIZE)
        force = self.DeclareVectorInputPort("obstacle_force", 3)
        self.DeclareVectorOutputPort(
            "navigation_force",
            3,
            lambda context, out: out.SetFromVector(force.Eval(context)),
            prerequisites_of_calc={force.ticket()},
        )
        self.DeclareVectorOutputPort(
            "goal_force_terms",
            9,
            lambda context, out: out.SetFromVector(np.zeros(9)),
            prerequisites_of_calc={self.nothing_ticket()},
        )
        self.DeclareVectorOutputPort(
            "mode",
            1,
            lambda context, out: out.SetAtIndex(0, float(MODE_PD)),
            prerequisites_of_calc={self.nothing_ticket()},
        )
