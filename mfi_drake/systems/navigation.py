"""The navigation LeafSystems: thin adapters from named ports to the fields
of `maths.fields` (MFI, eq 11–21) and `maths.baselines` (APF, GF); a
user's own field has its systems in `systems.user_field`.

A method is two systems with the same ports whatever the method:
a navigator ("state", "obstacle" → "obstacle_force" F_o, 3, and
"obstacle_force_terms", 6) and a goal attraction ("state", "obstacle_force"
→ "navigation_force" F_n, 3, "goal_force_terms", 9, "mode", 1).

What the 6 obstacle terms hold: MFI [F, F_a] (eq 12, eq 14); APF [F_rep, 0];
GF [S ṗ, F_rep]; a user field [F_n, 0]. The 9 goal terms: MFI [F_gc, F_v,
F_pd]; baselines [0, 0, F_att] with F_att = −∇U_att − k_d ṗ; a user field 0.

The MFI and baseline systems are templated on the scalar type with
`TemplateSystem.define` so that a diagram holding them converts to
AutoDiffXd for `Linearize`. Outputs declare narrow prerequisites so the
builder need not convert to symbolic form to look for algebraic loops. The
float systems keep their last result (`LastResult`), so the evaluation that
repeats the logger's at the start of every integrator step is a lookup; the
outputs that share a computation read it from there too. Every system
copies its parameters at construction: changing a parameter object later
changes no built diagram.
"""

import copy

import numpy as np
from pydrake.systems.framework import (
    EventStatus,
    LeafSystem_,
    UnrestrictedUpdateEvent_,
    WitnessFunctionDirection,
)
from pydrake.systems.scalar_conversion import TemplateSystem

from mfi_drake.maths import baselines, fields
from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    STATE_SIZE,
    position_velocity,
    signal_size,
)
from mfi_drake.systems.last_result import LastResult


def declare_obstacle_force_ports(system, terms, tickets: set) -> None:
    """Declares a navigator's outputs "obstacle_force" (F_o, 3) and
    "obstacle_force_terms" ([A, B], 6) on `system`, from `terms(context)` =
    (A, B, F_o, ...), computed once for both; `tickets` their
    prerequisites."""
    system.DeclareVectorOutputPort(
        "obstacle_force",
        3,
        lambda context, out: out.SetFromVector(terms(context)[2]),
        prerequisites_of_calc=tickets,
    )
    system.DeclareVectorOutputPort(
        "obstacle_force_terms",
        6,
        lambda context, out: out.SetFromVector(np.concatenate(terms(context)[:2])),
        prerequisites_of_calc=tickets,
    )


@TemplateSystem.define("ObstacleNavigator_")
def ObstacleNavigator_(T):
    class Impl(LeafSystem_[T]):
        """An obstacle field F_o = A + B as a system, its two terms (A, B)
        given by `field(v, r_o, seen, r_g, collision_radius, params)` (for MFI
        `fields.obstacle_field`: A = F, B = F_a of eq 11–15), summed over the
        obstacles of the reading (`fields.superposed`).

        The paper uses the closest obstacle point only. Its fields are those
        of currents on the obstacle surfaces, and fields of separate currents
        add, so the terms of the nearest few obstacles are summed. With the
        closest point alone, an obstacle hidden behind the one being followed
        appears head-on within turning distance, and between two obstacles
        the closest point jumps from side to side, so F_o flips with it.

        .. pydrake_system::

            name: ObstacleNavigator
            input_ports:
            - state
            - obstacle
            output_ports:
            - obstacle_force
            - obstacle_force_terms

        "state": 12; "obstacle": the readings of `maths.layout`;
        "obstacle_force": F_o (3); "obstacle_force_terms": [A, B] (6).
        """

        def _construct(
            self,
            field,
            params,
            goal,
            collision_radius,
            readings=OBSTACLE_COUNT,
            converter=None,
        ):
            LeafSystem_[T].__init__(self, converter)
            self.field = field
            self.readings = int(readings)  # the sensor's count
            self.params = copy.deepcopy(params)
            self.goal = np.array(goal, dtype=float)
            self.collision_radius = float(collision_radius)
            self._last = LastResult(enabled=T is float)
            self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
            self._obstacle = self.DeclareVectorInputPort(
                "obstacle", signal_size(self.readings)
            )
            tickets = {self._state.ticket(), self._obstacle.ticket()}
            declare_obstacle_force_ports(self, self._terms, tickets)

        def _construct_copy(self, other, converter=None):
            Impl._construct(
                self,
                other.field,
                other.params,
                other.goal,
                other.collision_radius,
                other.readings,
                converter=converter,
            )

        def _terms(self, context):
            """(A, B, F_o), computed once for both outputs."""
            x = self._state.Eval(context)
            obstacle = self._obstacle.Eval(context)
            key = x.tobytes() + obstacle.tobytes()
            return self._last(key, self.terms_of, x, obstacle)

        def terms_of(self, x, obstacle) -> tuple:
            """(A, B, F_o = A + B) at state x and the readings `obstacle`
            (the "obstacle" signal), without the ports."""
            p, v = position_velocity(x)
            A, B = fields.superposed(
                self.field,
                v,
                obstacle,
                self.goal - p,
                self.collision_radius,
                self.params,
            )
            return A, B, A + B

    return Impl


ObstacleNavigator = ObstacleNavigator_[None]


def MfiNavigator(params, goal, collision_radius: float, readings=OBSTACLE_COUNT):
    """The MFI obstacle field F_o = F + F_a (eq 11–15); terms [F, F_a]."""
    return ObstacleNavigator(
        fields.obstacle_field, params, goal, collision_radius, readings
    )


def ApfNavigator(params, goal, collision_radius: float, readings=OBSTACLE_COUNT):
    """APF's obstacle part: Khatib's repulsion; terms [F_rep, 0]."""
    return ObstacleNavigator(
        baselines.apf_obstacle_field, params, goal, collision_radius, readings
    )


def GfNavigator(params, goal, collision_radius: float, readings=OBSTACLE_COUNT):
    """GF's obstacle part: gyroscopic steering plus repulsion; terms
    [S ṗ, F_rep]."""
    return ObstacleNavigator(
        baselines.gf_obstacle_field, params, goal, collision_radius, readings
    )


def mode_witnesses(system, T, state, goal, params, write_mode) -> dict:
    """Eq 21's two witness functions on `system` (a LeafSystem_[T] whose
    input port `state` is the vehicle's 12-vector, flying to `goal` with
    MFI's `params`), by the mode each watches from: PD → cruise where
    `fields.cruise_guard` rises through zero, cruise → PD where
    `fields.pd_guard` falls to zero. Each switch calls `write_mode(state,
    mode)` on the discrete state. (`GoalAttractionSelector`'s; the compiled
    engine's lone vehicle, `systems.fleet.FleetChain`, declares the same.)"""

    def guard_of(guard):
        def value(x):
            p, v = position_velocity(x)
            return guard(p, v, goal, params)

        # The simulator evaluates the guard at both ends of every step.
        last = LastResult(enabled=T is float)

        def calc(context):
            x = state.Eval(context)
            return last(x.tobytes(), value, x)

        return calc

    def switch_to(mode):
        def update(context, event, discrete):
            write_mode(discrete, mode)

        return UnrestrictedUpdateEvent_[T](update)

    return {
        fields.MODE_PD: system.MakeWitnessFunction(
            "eq 21: PD -> cruise",
            WitnessFunctionDirection.kNegativeThenNonNegative,
            guard_of(fields.cruise_guard),
            switch_to(fields.MODE_CRUISE),
        ),
        fields.MODE_CRUISE: system.MakeWitnessFunction(
            "eq 21: cruise -> PD",
            WitnessFunctionDirection.kPositiveThenNonPositive,
            guard_of(fields.pd_guard),
            switch_to(fields.MODE_PD),
        ),
    }


# Over 80 lines: TemplateSystem.define wraps the whole class, whose
# methods are each short; its size is the class's, not one function's.
@TemplateSystem.define("GoalAttractionSelector_")
def GoalAttractionSelector_(T):
    class Impl(LeafSystem_[T]):
        """Goal attraction and the mode switch of eq 21: F_n from F_o.

        Cruise: F_n = F_o + F_gc + F_v (eq 16–19); PD: F_n = F_o + F_pd
        (eq 20). With repair (g) F_v also holds the drag of the turning
        force F_o + F_gc (`fields.lag_drag`), given the vehicle's `mass`
        (without it, as in the analysis diagrams, the drag is off; the
        registry's MFI methods pass the vehicle's).

        With `mode=None` the mode is a discrete state, set at
        initialization from the initial state and switched by witness
        functions (cruise_guard / pd_guard crossing zero), so the integrator
        localises each switch instead of stepping over a jump; and checked
        at the start of every step, which catches a guard crossed by a jump
        of the state it reads (a sampled state estimate jumps between steps,
        where no witness sees a crossing: it once held PD, whose saturated
        pull is not damped far from the goal, up to 4.9 m/s). A fixed
        `mode` (fields.MODE_PD or MODE_CRUISE) declares no state, for
        linearisation.

        .. pydrake_system::

            name: GoalAttractionSelector
            input_ports:
            - state
            - obstacle_force
            output_ports:
            - navigation_force
            - goal_force_terms
            - mode

        "state": 12; "obstacle_force": F_o (3); "navigation_force": F_n (3);
        "goal_force_terms": [F_gc, F_v, F_pd] (9); "mode": eq 21's mode (1).
        """

        def _construct(self, params, goal, mode=None, mass=None, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.params = copy.deepcopy(params)
            self.goal = np.array(goal, dtype=float)
            self.fixed_mode = mode
            self.mass = None if mass is None else float(mass)
            self._last = LastResult(enabled=T is float)
            self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
            self._obstacle_force = self.DeclareVectorInputPort("obstacle_force", 3)
            tickets = {self._state.ticket()}
            if self.params.lag_drag:  # repair (g): F_v depends on F_o
                tickets.add(self._obstacle_force.ticket())
            if mode is None:
                self._mode_index = self.DeclareDiscreteState(1)
                tickets.add(self.discrete_state_ticket(self._mode_index))
                self.DeclareInitializationUnrestrictedUpdateEvent(self._initialize)
                self.DeclarePerStepUnrestrictedUpdateEvent(self._follow_jump)
                self._witness = mode_witnesses(
                    self, T, self._state, self.goal, self.params, self._write_mode
                )
            self.DeclareVectorOutputPort(
                "navigation_force",
                3,
                self._calc_force,
                prerequisites_of_calc=tickets | {self._obstacle_force.ticket()},
            )
            self.DeclareVectorOutputPort(
                "goal_force_terms",
                9,
                lambda context, out: out.SetFromVector(
                    np.concatenate(self._terms(context))
                ),
                prerequisites_of_calc=tickets,
            )
            if mode is None:
                self.DeclareStateOutputPort("mode", self._mode_index)
            else:
                self.DeclareVectorOutputPort(
                    "mode",
                    1,
                    lambda context, out: out.SetAtIndex(0, float(mode)),
                    prerequisites_of_calc={self.nothing_ticket()},
                )

        def _construct_copy(self, other, converter=None):
            Impl._construct(
                self,
                other.params,
                other.goal,
                other.fixed_mode,
                other.mass,
                converter=converter,
            )

        def mode(self, context) -> int:
            if self.fixed_mode is not None:
                return self.fixed_mode
            # The only discrete state group: get_discrete_state_vector() is
            # cheaper than get_discrete_state(index).
            value = context.get_discrete_state_vector().GetAtIndex(0)
            return round(value if isinstance(value, float) else value.value())

        def initial_mode(self, x) -> int:
            """The mode eq 21 selects at rest-or-moving state x from scratch."""
            return self.next_mode(fields.MODE_PD, x)

        def next_mode(self, mode: int, x) -> int:
            """The mode eq 21 selects from `mode` at state x: switched where
            the guard that mode's witness function watches has been crossed
            (`fields.next_mode`)."""
            p, v = position_velocity(x)
            return fields.next_mode(mode, p, v, self.goal, self.params)

        def _write_mode(self, state, mode: int) -> None:
            state.get_mutable_discrete_state(self._mode_index).SetAtIndex(
                0, float(mode)
            )

        def _initialize(self, context, state):
            self._write_mode(state, self.initial_mode(self._state.Eval(context)))

        def _follow_jump(self, context, state):
            """The mode eq 21 asks for if a guard is already crossed."""
            mode = self.mode(context)
            new = self.next_mode(mode, self._state.Eval(context))
            if new == mode:
                return EventStatus.DidNothing()
            self._write_mode(state, new)
            return EventStatus.Succeeded()

        def DoGetWitnessFunctions(self, context):
            if self.fixed_mode is not None:
                return []
            return [self._witness[self.mode(context)]]

        def _terms(self, context, F_o=None):
            """(F_gc, F_v, F_pd), computed once for both outputs; F_o, the
            "obstacle_force" input, is read only where repair (g) needs it."""
            x = self._state.Eval(context)
            mode = self.mode(context)
            if (
                mode == fields.MODE_CRUISE
                and self.params.lag_drag
                and self.mass is not None
            ):
                if F_o is None:
                    F_o = self._obstacle_force.Eval(context)
                key = (mode, x.tobytes(), F_o.tobytes())
                return self._last(key, self._goal_terms, mode, x, F_o)
            return self._last((mode, x.tobytes()), self._goal_terms, mode, x)

        def _goal_terms(self, mode, x, F_o=None):
            p, v = position_velocity(x)
            return fields.goal_terms(
                mode, p, v, self.goal, self.params, F_o=F_o, mass=self.mass
            )

        def _calc_force(self, context, output):
            F_o = self._obstacle_force.Eval(context)
            F_gc, F_v, F_pd = self._terms(context, F_o)
            output.SetFromVector(F_o + F_gc + F_v + F_pd)

    return Impl


GoalAttractionSelector = GoalAttractionSelector_[None]


@TemplateSystem.define("PotentialGoalAttraction_")
def PotentialGoalAttraction_(T):
    class Impl(LeafSystem_[T]):
        """The baselines' goal attraction: F_n = F_o + F_att with
        F_att = −∇U_att − k_d ṗ (`baselines.attraction_field`); always "PD"
        (eq 20 with Khatib's velocity limit), no cruise mode.

        .. pydrake_system::

            name: PotentialGoalAttraction
            input_ports:
            - state
            - obstacle_force
            output_ports:
            - navigation_force
            - goal_force_terms
            - mode

        "goal_force_terms": [0, 0, F_att] (9, laid out as the selector's
        [F_gc, F_v, F_pd]); "mode": always fields.MODE_PD.
        """

        def _construct(self, attraction, goal, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.attraction = copy.deepcopy(attraction)
            self.goal = np.array(goal, dtype=float)
            self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
            self._obstacle_force = self.DeclareVectorInputPort("obstacle_force", 3)
            state = {self._state.ticket()}
            self.DeclareVectorOutputPort(
                "navigation_force",
                3,
                lambda context, out: out.SetFromVector(
                    self._obstacle_force.Eval(context) + self._attraction(context)
                ),
                prerequisites_of_calc=state | {self._obstacle_force.ticket()},
            )
            self.DeclareVectorOutputPort(
                "goal_force_terms",
                9,
                lambda context, out: out.SetFromVector(
                    np.concatenate([np.zeros(6), self._attraction(context)])
                ),
                prerequisites_of_calc=state,
            )
            self.DeclareVectorOutputPort(
                "mode",
                1,
                lambda context, out: out.SetAtIndex(0, float(fields.MODE_PD)),
                prerequisites_of_calc={self.nothing_ticket()},
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.attraction, other.goal, converter=converter)

        def _attraction(self, context):
            p, v = position_velocity(self._state.Eval(context))
            return baselines.attraction_field(p, v, self.goal, self.attraction)

    return Impl


PotentialGoalAttraction = PotentialGoalAttraction_[None]
