"""`EscapeNavigator`: MFI with the escape rule of `maths.escape` and the
memory it builds in flight, for method "mfi" (docs/nonconvex.md).

The memory is the system's one discrete state group (`escape.memory_size(count)`
floats), set at initialization and updated by a per-step discrete
update event: a flight is deterministic and replayable, and the event
forces no step boundaries, so until the first trap (or concave corner,
below) the flight is MFI's step for step. Once the memory says TRAPPED
the event ends the flight (`EventStatus.ReachedTermination`, message
`TRAPPED_MESSAGE`): the goal cannot be reached.

Method "mfi" pairs it with MFI's `GoalAttractionSelector` aimed at the
goal (eq 16–21 unchanged, the terminal PD included). While the memory
follows a surface, MFI's fields are aimed at the subgoal ĝ instead: F_o is
eq 11–15 with r_g = ĝ − p, and "obstacle_force" adds the redirection
F_gc(ĝ) − F_gc(g) (eq 16–18), which turns the selector's cruise pull
toward the goal into one toward ĝ (repair (g)'s drag then sees F_o +
F_gc(ĝ), the turning force flown). The redirection is ⟂ v, as F_gc is:
it does no work. Eq 19's setpoint is the rule's follow_speed while
following and, in any phase but PASS (through a door), at most
`escape_steering.corner_speed` in a concave corner (the corner brake,
`EscapeParams.corner_brake`): "obstacle_force"
adds F_v(setpoint) − F_v(v_d), which brakes along −l_a.
"obstacle_force_terms" holds [F, F_a + redirection + brake]: the maths
is `escape_steering.escape_terms`, which the compiled engine's chain calls too
(`maths.fleet.fleet_chain`, the memory in `systems.fleet.FleetChain`). The ground's
height (`ground`, None without one) tells the rule which reading is the
ground: never followed, and nothing goes under it.

In a fleet (`scene`) the memory, the subgoal and the corner brake read the
input "scene", the sphere sensor's readings of the static scene without
the other vehicles (`OtherVehicleReadings`' "scene"), and eq 11–15 every
reading of "obstacle", the others among them: they are moving obstacles
that MFI's field turns the vehicle round, with the velocity relative to
each where `relative` is given (`escape_steering.relative_escape_terms`, as the
memoryless navigator's `systems.relative.RelativeNavigator`). Alone,
"obstacle" is both.
Float only: `analyze` linearises the memoryless chain (`MfiNavigator`).
"""

import copy

import numpy as np
from pydrake.systems.framework import EventStatus, LeafSystem

from mfi_drake.config.dynamic import RelativeVelocity
from mfi_drake.maths import escape, escape_steering, fields
from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    STATE_SIZE,
    position_velocity,
    signal_size,
)
from mfi_drake.maths.motion import PACE_BLEND_SPEED
from mfi_drake.systems.last_result import LastResult
from mfi_drake.systems.navigation import declare_obstacle_force_ports

DEFAULT_RULE = escape.EscapeParams()
TRAPPED_MESSAGE = "trapped: the escape rule has run out of options"


class EscapeNavigator(LeafSystem):
    """MFI's obstacle field aimed at the escape rule's subgoal, with the
    memory as discrete state (see the module docstring).

    .. pydrake_system::

        name: EscapeNavigator
        input_ports:
        - state
        - obstacle
        - scene (optional)
        - obstacle_velocity (optional)
        - vehicle_readings (optional)
        - goal_mode
        output_ports:
        - obstacle_force
        - obstacle_force_terms
        - escape

    "escape": [phase, subgoal (3)] (`escape.TOWARD`, FOLLOW or TRAPPED).
    "goal_mode": eq 21's mode, the `GoalAttractionSelector`'s output "mode"
    (a state output: no algebraic loop); the redirection and the corner
    brake act only in its cruise mode (`escape_steering.steering`).

    `scene` (a fleet): the input "scene", the static scene's readings,
    which the memory reads instead of "obstacle". `relative` (a fleet's
    `relative_velocity`, enabled): the inputs "obstacle_velocity" and
    "vehicle_readings" (`OtherVehicleReadings`'), each reading's field with
    the velocity relative to it and the rule of the road (`keep_right`).
    `readings`: the sensor's count, which sizes the inputs and the memory.
    """

    def __init__(
        self,
        params,
        goal,
        collision_radius: float,
        mass: float,
        rule: escape.EscapeParams = DEFAULT_RULE,
        ground: float | None = None,
        scene: bool = False,
        relative: RelativeVelocity | None = None,
        readings: int = OBSTACLE_COUNT,
    ):
        super().__init__()
        self.readings = int(readings)
        size = signal_size(self.readings)
        self.params = copy.deepcopy(params)
        self.rule = copy.deepcopy(rule)
        self.goal = np.array(goal, dtype=float)
        self.collision_radius = float(collision_radius)
        self.mass = float(mass)
        # The ground's height (None: none): never followed, nothing under it.
        self.ground = None if ground is None else float(ground)
        # Eq 19's brake rate k = K_v/m gives the corner's setpoint gain.
        k = self.params.K_v / self.mass
        self._rate = escape_steering.corner_rate(k, self.params.v_d, self.params.r_b)
        self._last = LastResult()
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self._obstacle = self.DeclareVectorInputPort("obstacle", size)
        self._memory = self.DeclareDiscreteState(escape.memory_size(self.readings))
        self._goal_mode = self.DeclareVectorInputPort("goal_mode", 1)
        tickets = {
            self._state.ticket(),
            self._obstacle.ticket(),
            self._goal_mode.ticket(),
            self.discrete_state_ticket(self._memory),
        }
        # A fleet's: the static scene (the memory's), the others' velocities.
        self._scene = self._obstacle
        if scene:
            self._scene = self.DeclareVectorInputPort("scene", size)
            tickets.add(self._scene.ticket())
        self._relative = None
        if relative is not None:
            self._relative = (
                relative.keep_right,
                relative.own_pace,
                self.DeclareVectorInputPort("obstacle_velocity", 3 * self.readings),
                self.DeclareVectorInputPort("vehicle_readings", self.readings),
            )
            tickets |= {port.ticket() for port in self._relative[2:]}
        # Discrete, not unrestricted, updates: a new memory invalidates what
        # reads it, not the plant's state (the sensor's query stays cached).
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)
        self.DeclarePerStepDiscreteUpdateEvent(self._update)
        declare_obstacle_force_ports(self, self._terms, tickets)
        self.DeclareVectorOutputPort(
            "escape",
            4,
            lambda context, out: out.SetFromVector(
                [self.memory(context)[escape.PHASE], *self._terms(context)[3]]
            ),
            prerequisites_of_calc=tickets,
        )

    def memory(self, context) -> np.ndarray:
        return context.get_discrete_state_vector().CopyToVector()

    def initial_memory(self, x) -> np.ndarray:
        """The memory at initialization, the vehicle at state x."""
        p, _ = position_velocity(x)
        return escape.initial_memory(p, self.goal, self.readings)

    def next_memory(self, memory, t: float, x, scene) -> np.ndarray:
        """The memory after the update at the start of a step at time t
        (state x, the static scene's readings `scene`: a lone vehicle's
        readings, in a fleet the input "scene"), as the per-step event
        makes it; `flight.step.NavigationStep` makes it so between two
        calls."""
        p, v = position_velocity(x)
        return escape.update_memory(
            memory,
            t,
            p,
            v,
            scene,
            self.goal,
            self.collision_radius,
            self.rule,
            self.ground,
        )

    def _initialize(self, context, discrete_state):
        memory = self.initial_memory(self._state.Eval(context))
        discrete_state.get_mutable_vector(self._memory).SetFromVector(memory)

    def _update(self, context, discrete_state):
        memory = self.memory(context)
        new = self.next_memory(
            memory,
            context.get_time(),
            self._state.Eval(context),
            self._scene.Eval(context),
        )
        discrete_state.get_mutable_vector(self._memory).SetFromVector(new)
        if new[escape.PHASE] == escape.TRAPPED:
            return EventStatus.ReachedTermination(self, TRAPPED_MESSAGE)
        if np.array_equal(new, memory):
            return EventStatus.DidNothing()
        return EventStatus.Succeeded()

    def _terms(self, context):
        """(F, F_a + redirection, F_o, subgoal), computed once for the
        outputs."""
        x = self._state.Eval(context)
        obstacle = self._obstacle.Eval(context)
        scene = self._scene.Eval(context)
        memory = self.memory(context)
        mode = self._goal_mode.Eval(context)
        moving = ()  # the others' velocities and rule of the road (relative)
        if self._relative is not None:
            keep_right, _, velocity, vehicles = self._relative
            moving = (velocity.Eval(context), keep_right * vehicles.Eval(context))
        key = b"".join(a.tobytes() for a in (x, obstacle, scene, memory, mode, *moving))
        cruise = round(mode[0]) == fields.MODE_CRUISE
        return self._last(
            key, self.terms_of, x, obstacle, memory, cruise, scene, *moving
        )

    def terms_of(
        self, x, obstacle, memory, cruise: bool, scene=None, u=None, turns=None
    ) -> tuple:
        """(F, F_a + redirection, F_o, subgoal) at the state x, readings
        `obstacle` and `memory`, in eq 21's cruise mode or not (`cruise`);
        `scene` (a fleet's static scene, None: `obstacle`) and, with the
        relative velocity, each reading's u and turn
        (`escape_steering.relative_escape_terms`)."""
        scene = obstacle if scene is None else scene
        if u is not None:
            F_o, terms, target = escape_steering.relative_escape_terms(
                fields.obstacle_field,
                memory,
                x,
                scene,
                obstacle,
                u,
                turns,
                self.goal,
                self.collision_radius,
                self.params,
                self.rule,
                self._rate,
                self.ground,
                self._relative[1],
                PACE_BLEND_SPEED,
                cruise,
            )
            return terms[:3], terms[3:], F_o, target
        p, v = position_velocity(x)
        A, B, target = escape_steering.escape_terms(
            fields.obstacle_field,
            memory,
            p,
            v,
            scene,
            obstacle,
            self.goal,
            self.collision_radius,
            self.params,
            self.rule,
            self._rate,
            self.ground,
            cruise,
        )
        return A, B, A + B, target
