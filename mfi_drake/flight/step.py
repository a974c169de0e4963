"""The navigation chain outside Drake's Simulator, one call at a time: for
a flight stack (a ROS 2 node, a PX4 offboard loop) that has its own state
estimate and obstacle points and runs at its own rate.

`NavigationStep.step(state, points)` turns the vehicle's state and the
closest points of the obstacles it perceives into the navigation force F_n,
the attitude setpoint and thrust, and the rotor forces, as the diagram of
`flight.diagram` would at the same inputs.

It evaluates the very systems the diagram holds (the registry's navigator
and goal attraction, `AttitudePD`, `RotorMixer`), each in a context of its
own with its inputs fixed, in the diagram's order. The registry's entries
are system factories, and a user's field is reachable only through its
system: evaluating the systems is the one path that serves every method
with no second table of which maths function each method calls.

Eq 21's mode is the object's state, kept in the goal attraction's context.
The Simulator switches it where a witness function sees a guard cross
zero; between two calls the object switches it where the guard it watches
has been crossed since the last call (`GoalAttractionSelector.next_mode`,
the guard functions the witness functions evaluate). A guard crossed and
crossed back between two calls goes unseen, as in any sampled loop.

The escape rule's memory (mfi, `systems.escape.EscapeNavigator`) is
the object's state too, kept in the navigator's context: set from the
first call's state as the diagram's initialization sets it, then updated
at every call, before the outputs, as the diagram's per-step event updates
it at the start of each integrator step (`EscapeNavigator.next_memory`).
It measures progress over the calls' times `t`.
"""

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from mfi_drake.config.navigation import navigation_config
from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.scenario import Scenario, SphereSensor, check_scenario
from mfi_drake.config.vehicles import Vehicle, as_vehicle
from mfi_drake.flight.methods import Method, resolve_method
from mfi_drake.maths.layout import STATE_SIZE, point_readings, position_velocity
from mfi_drake.systems.control import AttitudePD, RotorMixer
from mfi_drake.systems.escape import EscapeNavigator
from mfi_drake.systems.navigation import GoalAttractionSelector

WHERE = "NavigationStep"  # what the errors name


@dataclass(frozen=True)
class StepOutput:
    """What one call of `NavigationStep.step` gives (world frame, z up)."""

    navigation_force: np.ndarray  # F_n [N] (3), eq 21
    obstacle_force: np.ndarray  # F_o [N] (3); a user's field: its F_n
    attitude_setpoint: np.ndarray  # [T [N], roll_d, pitch_d, yaw_d [rad]] (4)
    propeller_force: np.ndarray  # u (4), QuadrotorPlant's input: rotor commands
    mode: int  # eq 21's mode: fields.MODE_PD (0) or fields.MODE_CRUISE (1)
    obstacle: np.ndarray  # the readings used (4 a reading), the "obstacle" signal
    # The escape rule's [phase, subgoal (3)] (mfi; None without the rule):
    # phase maths.escape.TOWARD, FOLLOW, TRAPPED (the goal cannot be
    # reached: the diagram ends its flight there) or PASS.
    escape: np.ndarray | None = None

    @property
    def thrust(self) -> float:
        """The collective thrust T [N] of the attitude setpoint."""
        return float(self.attitude_setpoint[0])


class NavigationStep:
    """A method's navigation chain (navigator, goal attraction, attitude PD,
    mixer) as a function of the state and the obstacle points, carrying eq
    21's mode between calls.

    `goal`: [x, y, z] [m]; `method`: a name of `METHODS`, "MODULE:NAME" of a
    user's field or the field function (as `simulate` takes it); `vehicle`:
    a preset's name or a `Vehicle` (`config.vehicles.as_vehicle`);
    `navigator`: overrides of the scenario's `navigator` parameters (a
    `NavigatorParams`, or a dict of its fields),
    which hold MFI's gains and the attitude PD's of every method;
    `sensor_radius`: r_s [m], the sphere sensor's (default
    `SphereSensor().radius`); `readings`: how many obstacles it reports
    (default `SphereSensor().readings`). For every other parameter (the baselines'
    gains, a user field's `field_gains`), `from_scenario`. Bad arguments
    raise ValueError (`MethodError`, `ScenarioError`) naming them.
    """

    def __init__(
        self,
        goal,
        method: "str | Callable | Method" = "mfi",
        vehicle: "str | Vehicle" = "drake_default",
        navigator: "NavigatorParams | dict | None" = None,
        sensor_radius: float | None = None,
        readings: int | None = None,
    ):
        scenario = Scenario(
            name=WHERE,
            goal=[float(g) for g in _finite(goal, (3,), "goal", "[x, y, z] [m]")],
            vehicle=vehicle,
            navigator=_navigator(navigator),
        )
        if sensor_radius is not None:
            scenario.sensor.radius = sensor_radius
        if readings is not None:
            scenario.sensor.readings = readings
        self._build(scenario, method)

    @classmethod
    def from_scenario(
        cls, scenario: Scenario, method: "str | Callable | Method" = "mfi"
    ) -> "NavigationStep":
        """The chain that `simulate(scenario, method)` flies, for the
        scenario's goal, vehicle, parameters and sphere sensor's radius and
        readings. In
        a dynamic scene the diagram's navigator also reads the obstacles'
        velocities (`systems.relative`), and a `faults:` block sits around
        the chain: the step has neither, it reads points and the state
        estimate it is given."""
        step = cls.__new__(cls)
        step._build(scenario, method)
        return step

    def _build(self, scenario: Scenario, method) -> None:
        check_scenario(scenario, scenario.name)
        if not isinstance(scenario.sensor, SphereSensor):
            raise ValueError(
                f"{WHERE}: sensor = {type(scenario.sensor).__name__}: must be a "
                "SphereSensor (the step reads the points within its radius)"
            )
        self.method = resolve_method(method)
        self.scenario = scenario
        self.goal = np.array(scenario.goal, float)
        self.sensor_radius = float(scenario.sensor.radius)
        self.readings = scenario.sensor.readings
        vehicle = as_vehicle(scenario.vehicle)
        config = navigation_config(scenario)
        self._chain = [
            self.method.navigator(config, vehicle),
            self.method.goal_attraction(config, vehicle),
            AttitudePD(vehicle, scenario.navigator),
            RotorMixer(vehicle),
        ]
        self._contexts = [system.CreateDefaultContext() for system in self._chain]
        # Each input fixed once; a call writes into the fixed values (half
        # the cost of fixing them anew).
        self._inputs = [
            {
                port.get_name(): port.FixValue(context, np.zeros(port.size()))
                for port in map(system.get_input_port, range(system.num_input_ports()))
            }
            for system, context in zip(self._chain, self._contexts, strict=True)
        ]
        self._selector = self._chain[1]
        # Only the MFI selector holds eq 21's mode as state; the baselines'
        # and a user field's goal attractions stay in PD.
        self._switches = (
            isinstance(self._selector, GoalAttractionSelector)
            and self._selector.fixed_mode is None
        )
        self._remembers = isinstance(self._chain[0], EscapeNavigator)
        self.reset()

    def reset(self) -> None:
        """Forgets eq 21's mode and the escape rule's memory: the next call
        sets them from scratch, as the diagram does at initialization."""
        self._mode: int | None = None
        self._time: float | None = None  # of the last call, with the memory

    @property
    def memory(self) -> np.ndarray | None:
        """The escape rule's memory after the last call (`maths.escape`'s
        layout; None for a method without the rule, or before a call)."""
        if not self._remembers or self._time is None:
            return None
        return self._contexts[0].get_discrete_state_vector().CopyToVector()

    @property
    def mode(self) -> int | None:
        """Eq 21's mode after the last call (None before the first)."""
        return self._mode

    def step(self, state, points, t: float | None = None) -> StepOutput:
        """The chain's outputs at `state` (QuadrotorPlant's 12-vector, see
        `maths.layout`) with the obstacles whose closest points are `points`
        (k × 3, world frame [m], any k ≥ 0): the `readings` nearest
        within the sensor radius are read, as the sphere sensor reads them
        (`layout.point_readings`). First switches eq 21's mode if a guard
        has been crossed since the last call, and updates the escape rule's
        memory (mfi). `t` [s]: the time a user's field's errors name and
        the escape rule's memory measures progress over (default 0: the
        rule then never sees time pass, and never declares a trap); it may
        not go back between two calls of a method with the rule (ValueError;
        `reset` first)."""
        x = _finite(state, (STATE_SIZE,), "state", "QuadrotorPlant's 12-vector")
        array = _finite(points, None, "points", "k × 3 obstacle points [m]")
        if array.size == 0:
            array = array.reshape(0, 3)
        elif array.ndim != 2 or array.shape[1] != 3:
            _refuse("points", points, "must be k × 3 obstacle points [m]")
        p, _ = position_velocity(x)
        obstacle = point_readings(p, array, self.sensor_radius, self.readings)
        navigator, selector, attitude, mixer = self._contexts
        navigator.SetTime(0.0 if t is None else float(t))
        if self._switches:
            self._switch_mode(x)
        if self._remembers:
            self._remember(x, obstacle, navigator.get_time())
        inputs = {"state": x, "obstacle": obstacle}
        if self._remembers:  # eq 21's mode, as the selector's output gives it
            inputs["goal_mode"] = self._selector.GetOutputPort("mode").Eval(selector)
        F_o = self._evaluate(0, inputs, "obstacle_force")
        F_n = self._evaluate(1, {"state": x, "obstacle_force": F_o}, "navigation_force")
        setpoint = self._evaluate(
            2, {"navigation_force": F_n, "state": x}, "attitude_setpoint"
        )
        thrust_torque = self._chain[2].GetOutputPort("thrust_torque").Eval(attitude)
        u = self._evaluate(3, {"thrust_torque": thrust_torque}, "propeller_force")
        self._mode = round(self._selector.GetOutputPort("mode").Eval(selector)[0])
        escape = None
        if self._remembers:
            escape = self._chain[0].GetOutputPort("escape").Eval(navigator).copy()
        return StepOutput(F_n, F_o, setpoint, u, self._mode, obstacle, escape)

    def _remember(self, x: np.ndarray, obstacle: np.ndarray, t: float) -> None:
        """Writes the escape rule's memory at (t, x, obstacle) into the
        navigator's context: set from x at the first call, then updated."""
        navigator, context = self._chain[0], self._contexts[0]
        if self._time is None:
            memory = navigator.initial_memory(x)
        elif t < self._time:
            _refuse("t", t, f"must not go back (the last call's was {self._time})")
        else:
            memory = navigator.memory(context)
        memory = navigator.next_memory(memory, t, x, obstacle)
        context.get_mutable_discrete_state_vector().SetFromVector(memory)
        self._time = t

    def _switch_mode(self, x: np.ndarray) -> None:
        """Writes eq 21's mode at x into the selector's context: from
        scratch on the first call, else switched where a guard has been
        crossed since the last."""
        if self._mode is None:
            mode = self._selector.initial_mode(x)
        else:
            mode = self._selector.next_mode(self._mode, x)
        context = self._contexts[1]
        context.get_mutable_discrete_state_vector().SetAtIndex(0, float(mode))

    def _evaluate(self, k: int, inputs: dict, output: str) -> np.ndarray:
        """System k's `output` with its inputs fixed to `inputs`."""
        fixed = self._inputs[k]
        for name, value in inputs.items():
            fixed[name].GetMutableData().get_mutable_value().SetFromVector(value)
        return self._chain[k].GetOutputPort(output).Eval(self._contexts[k]).copy()


def _navigator(navigator: "NavigatorParams | dict | None") -> NavigatorParams:
    if navigator is None:
        return NavigatorParams()
    if isinstance(navigator, NavigatorParams):
        return navigator
    if not isinstance(navigator, dict):
        _refuse(
            "navigator", navigator, "must be a NavigatorParams or a dict of its fields"
        )
    known = NavigatorParams.__dataclass_fields__
    for name in navigator:
        if name not in known:
            _refuse(f"navigator.{name}", navigator[name], "no such parameter")
    return replace(NavigatorParams(), **navigator)


def _finite(value, shape: tuple | None, name: str, what: str) -> np.ndarray:
    """`value` as a float array of `shape` (any if None) with finite entries,
    else a ValueError naming `name`."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        _refuse(name, value, f"must be {what}")
    if shape is not None and array.shape != shape:
        _refuse(name, value, f"must be {what}, shape {shape}, not {array.shape}")
    if not np.all(np.isfinite(array)):
        _refuse(name, value, "must hold finite numbers")
    return array


def _refuse(name: str, value, reason: str):
    shown = " ".join(repr(value).split())
    if len(shown) > 80:
        shown = shown[:77] + "..."
    raise ValueError(f"{WHERE}: {name} = {shown}: {reason}")
