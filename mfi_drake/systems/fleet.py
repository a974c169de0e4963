"""A fleet's chain as one system, for a fleet flown by one integrator
(`flight.fleet`, docs/fleets.md "One integrator").

    plants' states ──▶ FleetChain ──rotor_forces──▶ plants
    scene sensors ──────▲    └──rows──▶ logger

`FleetChain` evaluates `maths.fleet.fleet_chain`, compiled
(`maths.compiled`), for every vehicle in one call: the per-call cost of a
Python system is paid once for the fleet, not once per vehicle and system.
Eq 21's modes are its discrete state, one a vehicle, updated at the start
of every integrator step (`fleet_modes`); for mfi the escape rule's
memory of each vehicle follows them in the same vector, updated then too
from that vehicle's readings of the static scene alone, in one compiled
call (`escape.fleet_memories`, as `EscapeNavigator` does one vehicle's),
and TRAPPED of any vehicle ends the flight as it does there
(`TRAPPED_MESSAGE`; `trapped` says whose). A lone vehicle (the compiled
engine, `engine: compiled`) also has the single-vehicle selector's witness
functions (`navigation.mode_witnesses`), so that the integrator locates
each switch as the card's diagram does; a fleet has none (a witness a
vehicle would cost a Python call a vehicle and step), its switches fall at
the start of the step after the crossing.
"""

import copy

import numpy as np
from pydrake.systems.framework import EventStatus, LeafSystem

from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.vehicles import Vehicle
from mfi_drake.maths import compiled, escape, escape_steering, fields, fleet
from mfi_drake.maths.fields import MODE_PD
from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    POSITION,
    ROTORS,
    STATE_SIZE,
    signal_size,
)
from mfi_drake.maths.quadcopter import attitude_gains, mixer_matrix
from mfi_drake.systems.escape import TRAPPED_MESSAGE
from mfi_drake.systems.last_result import LastResult
from mfi_drake.systems.navigation import mode_witnesses
from mfi_drake.systems.user_field import UserFieldError, UserFieldNavigator, call_field


class FleetChain(LeafSystem):
    """Every vehicle's sensor readings of the others, navigator, goal
    attraction (eq 21's selector or the baselines'), attitude PD and mixer
    (`maths.fleet.fleet_chain`).

    .. pydrake_system::

        name: FleetChain
        input_ports:
        - states
        - scene (optional)
        - obstacle_velocity (optional)
        output_ports:
        - rotor_forces
        - rows

    "states": the N plants' states, stacked (12 N); "scene": each vehicle's
    sphere-sensor readings of the scene, stacked (4 `readings` N; only
    with `scene`, else nothing); "obstacle_velocity": each vehicle's
    estimate of each of its scene readings' obstacle velocity, stacked (3
    `readings` a vehicle, `relative.ObstacleVelocityEstimator`'s; only
    with `moving`, where the chain flies the relative field,
    `maths.motion.relative_field`, as `relative.RelativeNavigator` does);
    "rotor_forces": u of every vehicle (4 N); "rows": each vehicle's
    `maths.fleet.row_layout`, what a single-vehicle diagram logs
    (`row_size` N).

    `field`, `attract`, `params`: the method's obstacle field and goal part
    (functions of modules `maths.compiled` compiles: MFI's
    `fields.obstacle_field` and eq 21's `fields.goal_terms`, or a
    baseline's field and `baselines.attraction_terms`) and their
    parameters; `attitude`: the attitude PD's (the scenario's `navigator`).
    `rule`: the escape rule's parameters (mfi: a memory a vehicle, which
    reads "scene" alone), `ground`: the ground's height it reads (None:
    none). `user`: a user's field's navigator, whose F_n the chain flies
    (`UserForces`; `attract` is then `fleet.no_goal_terms`). `readings`:
    the sensor's count, which sizes the ports, rows and memories (the
    compiled functions take any: one compilation serves every count).
    """

    def __init__(
        self,
        goals,
        field,
        attract,
        params,
        attitude: NavigatorParams,
        vehicle: Vehicle,
        sensor_radius: float,
        keep_right: float,
        own_pace: bool,
        blend_speed: float,
        scene: bool,
        rule: escape.EscapeParams | None = None,
        ground: float | None = None,
        moving: bool = False,
        user: UserFieldNavigator | None = None,
        readings: int = OBSTACLE_COUNT,
    ):
        super().__init__()
        self._goals = np.array(goals, float)
        n = len(self._goals)
        self.readings = int(readings)  # the sensor's count
        signal, velocity = signal_size(self.readings), 3 * self.readings
        K_P, K_D = attitude_gains(vehicle, attitude)
        # Copies of the parameters, in the compiled functions' form.
        self._constants = (
            compiled.record(params),
            compiled.compiled_form(attract),
            compiled.record(vehicle),
            compiled.record(attitude),
            K_P,
            K_D,
            np.linalg.inv(mixer_matrix(vehicle)),
            vehicle.collision_radius,
            float(sensor_radius),
            float(keep_right),
            bool(own_pace),
            float(blend_speed),
        )
        self._params = self._constants[0]
        # The escape rule's: its parameters, the corner brake's gain
        # (eq 19's k = K_v/m) and the ground (escape.NO_GROUND: none).
        self._rule = None if rule is None else compiled.record(rule)
        self._ground = escape.NO_GROUND if ground is None else float(ground)
        rate = 0.0  # MFI's parameters only
        if rule is not None:
            rate = escape_steering.corner_rate(
                params.K_v / vehicle.mass, params.v_d, params.r_b
            )
        self._escape = (self._rule, rate, self._ground)
        self._memory_size = 0 if rule is None else escape.memory_size(self.readings)
        self._radius = vehicle.collision_radius
        self._row_size = fleet.row_size(self.readings)
        self._forces = fleet.row_slices(self.readings)["propeller_force"]
        self._moving = bool(moving)
        self._user = None
        if user is not None:
            self._user = UserForces(user, n, self._radius, sensor_radius, self.readings)
        # Eq 21's modes switch with MFI's selector only; the baselines'
        # attraction stays in PD.
        self._selects = attract is fields.goal_terms
        self._compile(field, signal, velocity)
        self._states = self.DeclareVectorInputPort("states", STATE_SIZE * n)
        tickets = {self._states.ticket()}
        self._scene = None
        if scene:
            self._scene = self.DeclareVectorInputPort("scene", signal * n)
            tickets.add(self._scene.ticket())
        self._velocity = None
        if moving:
            self._velocity = self.DeclareVectorInputPort(
                "obstacle_velocity", velocity * n
            )
            tickets.add(self._velocity.ticket())
        # The one discrete state group: the modes, then the memories (mfi).
        self._modes = self.DeclareDiscreteState(
            np.concatenate(
                (np.full(n, float(MODE_PD)), np.zeros(n * self._memory_size))
            )
        )
        tickets.add(self.discrete_state_ticket(self._modes))
        if self._selects or rule is not None:
            self.DeclareInitializationUnrestrictedUpdateEvent(self._initialize)
            self.DeclarePerStepUnrestrictedUpdateEvent(self._update)
        self._witness = None
        if n == 1 and self._selects:
            self._witness = mode_witnesses(
                self,
                float,
                self._states,
                self._goals[0],
                copy.deepcopy(params),
                self._write_mode,
            )
        self._last = LastResult()
        self.DeclareVectorOutputPort(
            "rotor_forces",
            ROTORS * n,
            lambda context, out: out.SetFromVector(self._rows(context)[1]),
            prerequisites_of_calc=tickets,
        )
        self.DeclareVectorOutputPort(
            "rows",
            self._row_size * n,
            lambda context, out: out.SetFromVector(self._rows(context)[0].ravel()),
            prerequisites_of_calc=tickets,
        )

    def _compile(self, field, signal: int, velocity: int) -> None:
        """Compiled here, not within the flight: each function's entry for
        the types every later call passes (`compiled.specialised`)."""
        n = len(self._goals)
        functions = compiled.compiled(fleet)
        self._field = compiled.compiled_form(field)
        at_rest = np.zeros((n, STATE_SIZE))
        self._no_scene = np.zeros((n, signal))
        self._no_velocity = np.zeros((n, velocity))  # no estimate
        self._no_forces = np.zeros((0, 3))  # the method's field, no user's
        self._chain = compiled.specialised(
            functions.fleet_chain,
            self._field,
            at_rest,
            self._no_scene,
            self._no_velocity,
            self._moving,
            np.zeros(n),
            self._goals,
            *self._constants,
            np.zeros((n, self._memory_size)),
            *self._escape,
            self._no_forces,
            np.zeros((n, self._row_size)),
        )
        if self._rule is not None:
            self._update_memories = compiled.specialised(
                compiled.compiled(escape).fleet_memories,
                np.zeros((n, self._memory_size)),
                0.0,
                at_rest,
                self._no_scene,
                self._goals,
                self._radius,
                self._rule,
                self._ground,
            )
        if self._selects:
            self._next_modes = compiled.specialised(
                functions.fleet_modes,
                at_rest,
                self._goals,
                np.zeros(n),
                self._params,
                np.zeros(n),
            )

    def _initialize(self, context, state):
        """Eq 21's modes from scratch and the escape rule's first memories
        (`escape.initial_memory`)."""
        states, new = self._with_modes(context)
        if self._rule is not None:
            n = len(states)
            new[n:] = np.concatenate(
                [
                    escape.initial_memory(x[POSITION], goal, self.readings)
                    for x, goal in zip(states, self._goals, strict=True)
                ]
            )
        state.get_mutable_discrete_state(self._modes).SetFromVector(new)

    def _update(self, context, state):
        """Eq 21's modes and the escape rule's memories (`fleet_memories`, as
        `EscapeNavigator`'s update) at the start of a step; TRAPPED of any
        vehicle ends the flight as there."""
        states, new = self._with_modes(context)
        n = len(states)
        if self._rule is not None:
            scene = self._no_scene
            if self._scene is not None:
                scene = np.array(self._scene.Eval(context)).reshape(n, -1)
            new[n:] = self._update_memories(
                new[n:].reshape(n, self._memory_size),
                context.get_time(),
                states,
                scene,
                self._goals,
                self._radius,
                self._rule,
                self._ground,
            ).ravel()
        state.get_mutable_discrete_state(self._modes).SetFromVector(new)
        if self._rule is not None and any(self._trapped_in(new)):
            return EventStatus.ReachedTermination(self, TRAPPED_MESSAGE)
        return EventStatus.Succeeded()

    def memories(self, context) -> np.ndarray:
        """The escape rule's memories in `context` (N, `escape.memory_size`; N × 0
        without the rule)."""
        discrete = context.get_discrete_state_vector().CopyToVector()
        n = len(self._goals)
        return discrete[n:].reshape(n, self._memory_size)

    def trapped(self, context) -> list[bool]:
        """Whether each vehicle's memory is TRAPPED in `context` (all False
        without the rule)."""
        return self._trapped_in(context.get_discrete_state_vector().CopyToVector())

    def _trapped_in(self, discrete: np.ndarray) -> list[bool]:
        n = len(self._goals)
        if self._rule is None:
            return [False] * n
        phases = discrete[n:].reshape(n, self._memory_size)[:, escape.PHASE]
        return [bool(phase == escape.TRAPPED) for phase in phases]

    def _with_modes(self, context) -> tuple[np.ndarray, np.ndarray]:
        """(the states (N, 12), the discrete state with the modes eq 21
        selects at them: `fleet_modes`, where MFI's selector is flown)."""
        states = np.array(self._states.Eval(context)).reshape(-1, STATE_SIZE)
        now = context.get_discrete_state_vector().CopyToVector()
        new = now.copy()
        n = len(states)
        if self._selects:
            self._next_modes(states, self._goals, now[:n], self._params, new[:n])
        return states, new

    def _write_mode(self, state, mode: int) -> None:
        """A lone vehicle's switch of eq 21 (its witness functions')."""
        state.get_mutable_discrete_state(self._modes).SetAtIndex(0, float(mode))

    def DoGetWitnessFunctions(self, context):
        if self._witness is None:
            return []
        mode = context.get_discrete_state_vector().GetAtIndex(0)
        return [self._witness[round(mode)]]

    def _rows(self, context) -> tuple[np.ndarray, np.ndarray]:
        """(rows (N, `row_size`), the rotor forces (4 N)), computed once for
        both outputs."""
        # Copies: the compiled entries take writable C-contiguous arrays.
        states = np.array(self._states.Eval(context))
        scene = self._no_scene if self._scene is None else self._scene.Eval(context)
        # The only discrete state group: get_discrete_state_vector() costs a
        # fifth of get_discrete_state(index) (11 µs a call, 13 % of a lone
        # compiled flight).
        discrete = context.get_discrete_state_vector().CopyToVector()
        key = states.tobytes() + np.asarray(scene).tobytes() + discrete.tobytes()
        u = self._no_velocity
        if self._velocity is not None:
            u = self._velocity.Eval(context)
            key += u.tobytes()
        time = context.get_time()
        return self._last(key, self._evaluate, states, scene, u, discrete, time)

    def _evaluate(self, states, scene, u, discrete, time: float):
        n = len(self._goals)
        rows = np.empty((n, self._row_size))
        states = states.reshape(n, STATE_SIZE)
        scene = np.array(scene).reshape(n, signal_size(self.readings))
        u = np.array(u).reshape(n, 3 * self.readings)
        forces = self._no_forces
        if self._user is not None:
            forces = self._user(states, scene, u, self._goals, time)
        self._chain(
            self._field,
            states,
            scene,
            u,
            self._moving,
            discrete[:n],
            self._goals,
            *self._constants,
            discrete[n:].reshape(n, self._memory_size),
            *self._escape,
            forces,
            rows,
        )
        return rows, rows[:, self._forces].ravel()


class UserForces:
    """A user's field (a `UserFieldNavigator`'s, its parameters copied)
    compiled for N vehicles (`maths.compiled.user_field`): called with the
    fleet's states, readings of the scene and goals, each vehicle's F_n
    (`maths.fleet.user_forces`). Raises UserFieldError as `systems` does
    (`call_field` says it, at the vehicle that failed); what numba raises
    where it cannot compile the field, on construction. `readings`: the
    sensor's count."""

    def __init__(
        self,
        navigator: UserFieldNavigator,
        n: int,
        radius: float,
        sensor_radius: float,
        readings: int = OBSTACLE_COUNT,
    ):
        self._field, self._name = navigator.field, navigator.field_name
        self._gains = dict(navigator.gains)
        self._values = tuple(float(value) for value in self._gains.values())
        self._radius, self._reach = float(radius), float(sensor_radius)
        at_rest = np.zeros((n, STATE_SIZE))
        count = int(readings)
        readings = np.zeros((n, signal_size(count)))
        self._readings = compiled.specialised(
            compiled.compiled(fleet).fleet_readings,
            at_rest,
            readings,
            np.zeros((n, 3 * count)),
            self._radius,
            self._reach,
            readings,
        )
        self._forces, self._bound = compiled.user_field(
            self._field,
            tuple(self._gains),
            at_rest,
            readings,
            np.zeros((n, 3)),
            self._values,
            np.zeros((n, 3)),
        )

    def __call__(self, states, scene, u, goals, time: float) -> np.ndarray:
        """(N, 3): each vehicle's F_n at `states`, `scene`, `u` (the chain's
        arrays) toward `goals` at `time`."""
        readings = np.empty_like(scene)
        self._readings(states, scene, u, self._radius, self._reach, readings)
        forces = np.empty((len(states), 3))
        try:
            failed = self._forces(
                self._bound, states, readings, goals, self._values, forces
            )
        except Exception as e:  # raised within the field
            message = " ".join(str(e).split())
            said = f"raised {type(e).__name__}: {message}"
            self._say(states, readings, goals, time, range(len(states)), said)
        if failed >= 0:
            said = "returned no 3 finite numbers (F_n [N])"
            self._say(states, readings, goals, time, [failed], said)
        return forces

    def _say(self, states, readings, goals, time: float, vehicles, said: str):
        """Raises what `call_field` raises for the first of `vehicles` whose
        field fails at those inputs in Python (at its `readings`), as
        `systems` would fly it; else UserFieldError saying what the
        compiled field `said`."""
        for k in vehicles:
            call_field(
                self._field,
                self._name,
                self._gains,
                goals[k],
                states[k],
                readings[k],
                time,
            )
        raise UserFieldError(f"{self._name} at t = {time:.3f} s: {said} (compiled)")


class TrueRows(LeafSystem):
    """A lone vehicle's "rows" with the true state and readings in place of
    what its faults made of them (the compiled engine with faults: the
    chain reads the state estimate and the faulted readings, the log keeps
    the truth, as the card's diagram logs the plant's state and the
    sensor's output; `readings`: the sensor's count).

    .. pydrake_system::

        name: TrueRows
        input_ports:
        - rows
        - states
        - scene (optional)
        output_ports:
        - rows
    """

    def __init__(self, scene: bool, readings: int = OBSTACLE_COUNT):
        super().__init__()
        size = fleet.row_size(readings)
        self._rows = self.DeclareVectorInputPort("rows", size)
        self._states = self.DeclareVectorInputPort("states", STATE_SIZE)
        self._scene = None
        if scene:
            self._scene = self.DeclareVectorInputPort("scene", signal_size(readings))
        self._slices = fleet.row_slices(readings)
        self.DeclareVectorOutputPort("rows", size, self._calc)

    def _calc(self, context, output) -> None:
        row = np.array(self._rows.Eval(context))
        row[self._slices["state"]] = self._states.Eval(context)
        if self._scene is not None:
            row[self._slices["obstacle"]] = self._scene.Eval(context)
        output.SetFromVector(row)
