"""The controller LeafSystems: thin adapters from named ports to `fields` and
`quadcopter`.

Each is templated on the scalar type with `TemplateSystem.define` (as
Drake's Python examples do) so that a diagram holding them converts to
AutoDiffXd for `Linearize`. Outputs declare narrow prerequisites so the
builder need not convert to symbolic form to look for algebraic loops. The
float systems keep their last result (`LastResult`), so the evaluation that
repeats the logger's at the start of every integrator step is a lookup; the
outputs that share a computation read it from there too (a cache entry of
its own would add a Python callback to every evaluation).
"""

import numpy as np
from pydrake.systems.framework import (
    LeafSystem_,
    UnrestrictedUpdateEvent_,
    WitnessFunctionDirection,
)
from pydrake.systems.scalar_conversion import TemplateSystem

from mfi_drake import fields
from mfi_drake.last_result import LastResult
from mfi_drake.quadcopter import (
    attitude_gains,
    attitude_pd_torque,
    attitude_setpoint,
    desired_yaw,
    mix,
    mixer_matrix,
)
from mfi_drake.sensing import OBSTACLE_SIGNAL_SIZE
from mfi_drake.vehicles import Vehicle

STATE_SIZE = 12  # QuadrotorPlant's state


def _position_velocity(x):
    return x[0:3], x[6:9]


@TemplateSystem.define("ObstacleNavigator_")
def ObstacleNavigator_(T):
    class Impl(LeafSystem_[T]):
        """An obstacle field F_o = A + B as a system, its two terms (A, B)
        given by `field(v, r_o, seen, r_g, collision_radius, params)` (for MFI
        `fields.obstacle_field`: A = F, B = F_a of eq 11–15), summed over the
        obstacles of the reading.

        The paper uses the closest obstacle point only. Its fields are those
        of currents on the obstacle surfaces, and fields of separate currents
        add, so the terms of the nearest few obstacles are summed. With the
        closest point alone, an obstacle hidden behind the one being followed
        appears head-on within turning distance, and between two obstacles
        the closest point jumps from side to side, so F_o flips with it.

        Inputs: "state" (12), "obstacle" (readings [r_o, seen], `sensing`).
        Outputs: "obstacle_force" F_o (3), "obstacle_force_terms" [A, B] (6).
        """

        def _construct(self, field, params, goal, collision_radius, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.field = field
            self.params = params
            self.goal = np.asarray(goal, dtype=float)
            self.collision_radius = float(collision_radius)
            self._last = LastResult(enabled=T is float)
            self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
            self._obstacle = self.DeclareVectorInputPort(
                "obstacle", OBSTACLE_SIGNAL_SIZE
            )
            tickets = {self._state.ticket(), self._obstacle.ticket()}
            self.DeclareVectorOutputPort(
                "obstacle_force",
                3,
                lambda context, out: out.SetFromVector(self._terms(context)[2]),
                prerequisites_of_calc=tickets,
            )
            self.DeclareVectorOutputPort(
                "obstacle_force_terms",
                6,
                lambda context, out: out.SetFromVector(
                    np.concatenate(self._terms(context)[:2])
                ),
                prerequisites_of_calc=tickets,
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(
                self,
                other.field,
                other.params,
                other.goal,
                other.collision_radius,
                converter=converter,
            )

        def _terms(self, context):
            """(A, B, F_o), computed once for both outputs."""
            x = self._state.Eval(context)
            obstacle = self._obstacle.Eval(context)
            key = x.tobytes() + obstacle.tobytes()
            return self._last(key, self._terms_of, x, obstacle)

        def _terms_of(self, x, obstacle):
            p, v = _position_velocity(x)
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


def MfiNavigator(params, goal, collision_radius: float):
    """The MFI obstacle field F_o = F + F_a (eq 11–15); terms [F, F_a]."""
    return ObstacleNavigator(fields.obstacle_field, params, goal, collision_radius)


@TemplateSystem.define("GoalAttractionSelector_")
def GoalAttractionSelector_(T):
    class Impl(LeafSystem_[T]):
        """Goal attraction and the mode switch of eq 21: F_n from F_o.

        Cruise: F_n = F_o + F_gc + F_v (eq 16–19); PD: F_n = F_o + F_pd
        (eq 20). With `mode=None` the mode is a discrete state switched by
        witness functions (cruise_guard / pd_guard crossing zero), so the
        integrator localises each switch instead of stepping over a jump.
        A fixed `mode` (fields.MODE_PD or MODE_CRUISE) declares no state, for
        linearisation.

        Inputs: "state" (12), "obstacle_force" F_o (3).
        Outputs: "navigation_force" F_n (3), "goal_force_terms"
        [F_gc, F_v, F_pd] (9), "mode" (1).
        """

        def _construct(self, params, goal, mode=None, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.params = params
            self.goal = np.asarray(goal, dtype=float)
            self.fixed_mode = mode
            self._last = LastResult(enabled=T is float)
            self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
            self._obstacle_force = self.DeclareVectorInputPort("obstacle_force", 3)
            tickets = {self._state.ticket()}
            if mode is None:
                self._mode_index = self.DeclareDiscreteState(1)
                tickets.add(self.discrete_state_ticket(self._mode_index))
                to_cruise = UnrestrictedUpdateEvent_[T](
                    self._switch_to(fields.MODE_CRUISE)
                )
                to_pd = UnrestrictedUpdateEvent_[T](self._switch_to(fields.MODE_PD))
                self._witness = {
                    fields.MODE_PD: self.MakeWitnessFunction(
                        "eq 21: PD -> cruise",
                        WitnessFunctionDirection.kNegativeThenNonNegative,
                        self._guard(fields.cruise_guard),
                        to_cruise,
                    ),
                    fields.MODE_CRUISE: self.MakeWitnessFunction(
                        "eq 21: cruise -> PD",
                        WitnessFunctionDirection.kPositiveThenNonPositive,
                        self._guard(fields.pd_guard),
                        to_pd,
                    ),
                }
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
            self.DeclareVectorOutputPort(
                "mode",
                1,
                lambda context, out: out.SetAtIndex(0, float(self.mode(context))),
                prerequisites_of_calc=tickets - {self._state.ticket()}
                or {self.nothing_ticket()},
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(
                self, other.params, other.goal, other.fixed_mode, converter=converter
            )

        def mode(self, context) -> int:
            if self.fixed_mode is not None:
                return self.fixed_mode
            # The only discrete state group: get_discrete_state_vector() is
            # cheaper than get_discrete_state(index).
            value = context.get_discrete_state_vector().GetAtIndex(0)
            return round(value if isinstance(value, float) else value.value())

        def set_mode(self, context, mode: int) -> None:
            """Sets the mode state (e.g. the initial mode from the initial state)."""
            context.SetDiscreteState(self._mode_index, [float(mode)])

        def initial_mode(self, x) -> int:
            """The mode eq 21 selects at rest-or-moving state x from scratch."""
            p, v = _position_velocity(x)
            if fields.cruise_guard(p, v, self.goal, self.params) >= 0.0:
                return fields.MODE_CRUISE
            return fields.MODE_PD

        def _guard(self, guard):
            def value(x):
                p, v = _position_velocity(x)
                return guard(p, v, self.goal, self.params)

            # The simulator evaluates the guard at both ends of every step.
            last = LastResult(enabled=T is float)

            def calc(context):
                x = self._state.Eval(context)
                return last(x.tobytes(), value, x)

            return calc

        def _switch_to(self, mode):
            def update(context, event, state):
                state.get_mutable_discrete_state(self._mode_index).SetAtIndex(
                    0, float(mode)
                )

            return update

        def DoGetWitnessFunctions(self, context):
            if self.fixed_mode is not None:
                return []
            return [self._witness[self.mode(context)]]

        def _terms(self, context):
            """(F_gc, F_v, F_pd), computed once for both outputs."""
            x = self._state.Eval(context)
            mode = self.mode(context)
            return self._last((mode, x.tobytes()), self._goal_terms, mode, x)

        def _goal_terms(self, mode, x):
            p, v = _position_velocity(x)
            return fields.goal_terms(mode, p, v, self.goal, self.params)

        def _calc_force(self, context, output):
            F_gc, F_v, F_pd = self._terms(context)
            F_o = self._obstacle_force.Eval(context)
            output.SetFromVector(F_o + F_gc + F_v + F_pd)

    return Impl


GoalAttractionSelector = GoalAttractionSelector_[None]


@TemplateSystem.define("AttitudePD_")
def AttitudePD_(T):
    class Impl(LeafSystem_[T]):
        """Eq 22–25: thrust and roll/pitch/yaw PD torques from F_n.

        Inputs: "navigation_force" F_n (3), "state" (12).
        Outputs: "thrust_torque" [T, τx, τy, τz] (4), "attitude_setpoint"
        [T, roll_d, pitch_d, yaw_d] (4).
        """

        def _construct(self, vehicle, params, K_P=None, K_D=None, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.vehicle = vehicle
            self.params = params
            default_P, default_D = attitude_gains(vehicle, params)
            self.K_P = default_P if K_P is None else np.asarray(K_P, float)
            self.K_D = default_D if K_D is None else np.asarray(K_D, float)
            self._last = LastResult(enabled=T is float)
            self._force = self.DeclareVectorInputPort("navigation_force", 3)
            self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
            tickets = {self._force.ticket(), self._state.ticket()}
            self.DeclareVectorOutputPort(
                "thrust_torque",
                4,
                lambda context, out: out.SetFromVector(self._outputs(context)[0]),
                prerequisites_of_calc=tickets,
            )
            self.DeclareVectorOutputPort(
                "attitude_setpoint",
                4,
                lambda context, out: out.SetFromVector(self._outputs(context)[1]),
                prerequisites_of_calc=tickets,
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(
                self,
                other.vehicle,
                other.params,
                other.K_P,
                other.K_D,
                converter=converter,
            )

        def _outputs(self, context):
            """(thrust_torque, attitude_setpoint), computed once for both."""
            x = self._state.Eval(context)
            F_n = self._force.Eval(context)
            return self._last(x.tobytes() + F_n.tobytes(), self._outputs_of, x, F_n)

        def _outputs_of(self, x, F_n):
            yaw_d = desired_yaw(x[6:9], x[5], self.params)
            setpoint = attitude_setpoint(F_n, x[3:6], yaw_d, self.vehicle, self.params)
            tau = attitude_pd_torque(x[3:6], x[9:12], setpoint[1:4], self.K_P, self.K_D)
            return np.concatenate([setpoint[:1], tau]), setpoint

    return Impl


AttitudePD = AttitudePD_[None]


@TemplateSystem.define("RotorMixer_")
def RotorMixer_(T):
    class Impl(LeafSystem_[T]):
        """Eq 8 inverted for QuadrotorPlant's layout, clipped to [0, u_max].

        Input: "thrust_torque" (4). Outputs: "propeller_force" u (4) for the
        plant, "saturation" (1): how many rotors were clipped.
        """

        def _construct(self, vehicle: Vehicle, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.vehicle = vehicle
            self._D_inv = np.linalg.inv(mixer_matrix(vehicle)).tolist()
            self._last = LastResult(enabled=T is float)
            self._input = self.DeclareVectorInputPort("thrust_torque", 4)
            tickets = {self._input.ticket()}
            self.DeclareVectorOutputPort(
                "propeller_force",
                4,
                lambda context, out: out.SetFromVector(self._mix(context)[0]),
                prerequisites_of_calc=tickets,
            )
            self.DeclareVectorOutputPort(
                "saturation",
                1,
                lambda context, out: out.SetAtIndex(0, float(self._mix(context)[1])),
                prerequisites_of_calc=tickets,
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.vehicle, converter=converter)

        def _mix(self, context):
            thrust_torque = self._input.Eval(context)
            return self._last(thrust_torque.tobytes(), self._mix_of, thrust_torque)

        def _mix_of(self, thrust_torque):
            return mix(thrust_torque, self._D_inv, self.vehicle.u_max)

    return Impl


RotorMixer = RotorMixer_[None]
