"""A fleet flown by one integrator (`fleet_integration: one`, docs/fleets.md
"One integrator"):

    SceneGraph ──query──▶ FleetSceneSensor (only where the scene has
        │                  obstacles or a ground: every vehicle's readings)
        ▼                          │ scene
    plants' states ──▶ FleetChain ◀┘ ──rows──▶ logger
        ▲                  │ rotor_forces
        └── N QuadrotorPlants ◀┘

N of Drake's QuadrotorPlant, one `systems.fleet.FleetChain` (the method's
chain compiled, every vehicle in one call), one Simulator with the scenario's
error-controlled integrator, one logger: every vehicle sees the others
where they are, with no exchange. The other design, a diagram and
Simulator a vehicle exchanging states at `exchange_hz`, is
`fleet_exchange.fly_fleet`; `one_integrator.fly_one_integrator` flies this one.

A lone vehicle with `engine: compiled` is this diagram with N = 1: the
compiled engine (`flies_compiled`), the same chain as the card's diagram of
LeafSystems (`engine: systems`, `flight.diagram`) in one system. Among
moving obstacles it has that diagram's
`ObstacleMotion` and `ObstacleVelocityEstimator`, whose estimate reaches
FleetChain's "obstacle_velocity"; in a fleet one estimator a vehicle, of
its readings of the scene (`add_velocity_estimators`; the others' velocities
the chain knows, `maths.motion.vehicle_readings`). With faults (a lone
vehicle only) it has that diagram's `systems.faults` systems: the chain
reads the state estimate and the faulted readings, the plant the faulted
rotors, and `TrueRows` puts the truth back in the log (docs/robustness.md).
"""

import dataclasses

from pydrake.geometry import SceneGraph
from pydrake.systems.framework import DiagramBuilder, OutputPort
from pydrake.systems.primitives import (
    Demultiplexer,
    LogVectorOutput,
    Multiplexer,
)

from mfi_drake.config.dynamic import RelativeVelocity
from mfi_drake.config.faults import Faults
from mfi_drake.config.navigation import navigation_config
from mfi_drake.config.scenario import Scenario, ScenarioError, SphereSensor
from mfi_drake.config.vehicle_gains import for_vehicle
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.flight.builder import add_rotor_path
from mfi_drake.flight.diagram import add_obstacles, make_plant, vehicle_scenarios
from mfi_drake.flight.methods import Method, resolve_method
from mfi_drake.maths import baselines, compiled, fields, fleet
from mfi_drake.maths.layout import ROTORS, STATE_SIZE, signal_size
from mfi_drake.maths.motion import PACE_BLEND_SPEED
from mfi_drake.systems.escape import EscapeNavigator
from mfi_drake.systems.faults import (
    add_rotor_faults,
    add_sensor_faults,
    add_state_estimate,
    estimate_faulted,
    readings_faulted,
)
from mfi_drake.systems.fleet import FleetChain, TrueRows, UserForces
from mfi_drake.systems.navigation import (
    GoalAttractionSelector,
    ObstacleNavigator,
    PotentialGoalAttraction,
)
from mfi_drake.systems.relative import ObstacleVelocityEstimator
from mfi_drake.systems.sensors import FleetSceneSensor
from mfi_drake.systems.user_field import UserFieldNavigator


def flies_compiled(scenario: Scenario) -> bool:
    """Whether `scenario` flies on the compiled engine: `engine: compiled`,
    or a fleet on one integrator (compiled whatever its engine)."""
    fleet_on_one = bool(scenario.other_vehicles) and scenario.fleet_integration == "one"
    return scenario.engine == "compiled" or fleet_on_one


# The obstacle fields the compiled chain flies (`maths.compiled` compiles
# their modules): MFI's, APF's and GF's.
COMPILED_FIELDS = (
    fields.obstacle_field,
    baselines.apf_obstacle_field,
    baselines.gf_obstacle_field,
)


def unsupported(scenario: Scenario, method: "str | Method") -> str | None:
    """Why `scenario` cannot be flown by `method` on the compiled engine (a
    sentence naming the field or method), or None where it can: MFI's field
    and eq 21 selector (mfi, mfi-paper; mfi's escape rule, a memory a
    vehicle), APF's or GF's field and attraction, or a user's field numba
    compiles (`uncompiled_field`); the sphere sensor,
    moving obstacles (where `methods.escape_off` turns the escape rule
    off), faults for a lone vehicle, no point-cloud map; a fleet with the
    relative velocity."""
    method = resolve_method(method)
    navigator, selector = method_systems(scenario, method)
    mfi = (
        isinstance(selector, GoalAttractionSelector)
        and selector.mass is not None
        and selector.fixed_mode is None
    )
    escape = isinstance(navigator, EscapeNavigator)
    if isinstance(navigator, UserFieldNavigator):
        why = uncompiled_field(navigator)
        if why is not None:
            return f"method {method.name}: {why}"
    elif not (
        (escape or isinstance(navigator, ObstacleNavigator))
        and field_of(navigator) in COMPILED_FIELDS
        and (mfi or isinstance(selector, PotentialGoalAttraction))
    ):
        return (
            f"method {method.name}: the compiled chain flies the fields of mfi, "
            "mfi-memoryless, mfi-paper, apf and gf, and users' fields numba compiles"
        )
    if not isinstance(scenario.sensor, SphereSensor):
        return "sensor: the compiled chain flies the sphere sensor only"
    if scenario.faults != Faults() and scenario.other_vehicles:
        return "faults: the compiled chain flies them for a lone vehicle only"
    if scenario.map_points:
        return "world: the compiled chain flies no point-cloud map"
    if scenario.other_vehicles and not scenario.relative_velocity.enabled:
        return "relative_velocity.enabled = false: one integrator flies with it"
    return None


def uncompiled_field(navigator: UserFieldNavigator) -> str | None:
    """Why numba cannot compile a user's field (one line), or None where it
    can (compiled here, once per field and gains in a process: `UserForces`
    for one vehicle compiles what a fleet's calls too)."""
    try:
        UserForces(navigator, 1, 0.0, 0.0)
    except Exception as e:  # numba's errors, a gain that is no identifier
        return f"numba cannot compile the field: {compiled.compile_error(e)}"
    return None


def user_fallback(scenario: Scenario, method: "str | Method") -> str | None:
    """Why a lone vehicle asking for `engine: compiled` flies a user's
    field on `systems` instead (`uncompiled_field`), or None. Every other
    refusal of `unsupported` stands (`check_engine`); a fleet on one
    integrator has no `systems` form to fall back on."""
    if scenario.engine != "compiled" or scenario.other_vehicles:
        return None
    method = resolve_method(method)
    navigator, _ = method_systems(scenario, method)
    if not isinstance(navigator, UserFieldNavigator):
        return None
    why = uncompiled_field(navigator)
    return None if why is None else f"method {method.name}: {why}"


def field_of(navigator) -> object:
    """The obstacle field of a navigator system: an `ObstacleNavigator`'s,
    MFI's for `EscapeNavigator` (`escape_steering.escape_terms` aims it)."""
    if isinstance(navigator, EscapeNavigator):
        return fields.obstacle_field
    return navigator.field


def not_compiled(scenario: Scenario, methods: list) -> str | None:
    """Why `scenario` cannot be flown by every method of `methods` on the
    compiled engine (the first method's `unsupported` sentence), or None."""
    compiled = dataclasses.replace(scenario, engine="compiled")
    return next(filter(None, (unsupported(compiled, m) for m in methods)), None)


def on_compiled(scenario: Scenario, methods: list) -> Scenario | None:
    """`scenario` on the compiled engine, or None where a method of
    `methods` cannot be flown there (`not_compiled`): what `sweep` and
    `tune` fly by default (the engines fly the same flights)."""
    if not_compiled(scenario, methods) is not None:
        return None
    return dataclasses.replace(scenario, engine="compiled")


def method_systems(scenario: Scenario, method: Method) -> tuple:
    """(navigator, goal attraction): `method`'s systems for `scenario`,
    whose parameters the compiled chain copies."""
    vehicle, config = as_vehicle(scenario.vehicle), navigation_config(scenario)
    return method.navigator(config, vehicle), method.goal_attraction(config, vehicle)


def check_engine(scenario: Scenario, methods: list) -> None:
    """Raises ScenarioError where `scenario` flies on the compiled engine
    (`flies_compiled`: a fleet on one integrator, or `engine: compiled`)
    and a method of `methods` cannot be flown so (`unsupported`). A fleet's
    navigators are built first on either engine, so that what a method
    refuses in a fleet (mfi's, `methods`) is refused before anything
    flies."""
    for method in methods if scenario.other_vehicles else ():
        method_systems(scenario, resolve_method(method))
    if not flies_compiled(scenario):
        return
    asked, other = "engine = 'compiled'", "engine: systems"
    if scenario.engine != "compiled":
        asked, other = "fleet_integration = 'one'", "fleet_integration: separate"
    for method in methods:
        reason = unsupported(scenario, method)
        if reason is not None and user_fallback(scenario, method) is None:
            raise ScenarioError(
                f"{scenario.name}: {asked}: {reason} ({other} flies it)"
            )


def uses_estimate(scenario: Scenario, method: Method) -> bool:
    """Whether the chain reads obstacle velocities estimated from the
    readings where obstacles move: with the relative velocity on, for every
    method but a user's field (which gets the vehicle's own velocity)."""
    navigator, _ = method_systems(scenario, method)
    enabled = scenario.relative_velocity.enabled
    return enabled and not isinstance(navigator, UserFieldNavigator)


def chain_system(
    scenario: Scenario, method: Method, flown: list, scene: bool, relative: bool
) -> FleetChain:
    """The `FleetChain` flying `method` for the vehicles `flown` (their
    scenarios, `vehicle_scenarios`) with `scenario`'s gains: its input
    "scene" where `scene`, "obstacle_velocity" where `relative`."""
    vehicle = as_vehicle(scenario.vehicle)
    navigator, selector = method_systems(scenario, method)
    user = navigator if isinstance(navigator, UserFieldNavigator) else None
    attract = baselines.attraction_terms  # the goal part of the baselines,
    if isinstance(selector, GoalAttractionSelector):  # MFI's
        attract = fields.goal_terms
    elif user is not None:  # a user's field (its F_n, `PassThroughGoal`)
        attract = fleet.no_goal_terms
    estimate = scenario.relative_velocity
    gains = for_vehicle(scenario.navigator, vehicle)
    return FleetChain(
        [s.goal for s in flown],
        fields.obstacle_field if user else field_of(navigator),
        attract,
        gains if user else navigator.params,
        gains,
        vehicle,
        scenario.sensor.radius,
        estimate.keep_right,
        estimate.own_pace,
        PACE_BLEND_SPEED,
        scene,
        getattr(navigator, "rule", None),  # mfi's escape rule
        getattr(navigator, "ground", None),
        relative,
        user,
        scenario.sensor.readings,
    )


def add_velocity_estimators(
    builder: DiagramBuilder,
    estimate: RelativeVelocity,
    n: int,
    states_port: OutputPort,
    scene_port: OutputPort,
    chain: FleetChain,
) -> None:
    """One `ObstacleVelocityEstimator` a vehicle, each reading its state
    and its readings of the scene (a fleet's: split from the stacked ports,
    the estimates stacked again) into the chain's "obstacle_velocity"."""

    def split(port: OutputPort, size: int, name: str) -> list:
        if n == 1:
            return [port]
        demux = builder.AddNamedSystem(name, Demultiplexer(size * n, size))
        builder.Connect(port, demux.get_input_port(0))
        return [demux.get_output_port(k) for k in range(n)]

    count = chain.readings
    states = split(states_port, STATE_SIZE, "estimator_states")
    scenes = split(scene_port, signal_size(count), "estimator_scenes")
    target = chain.GetInputPort("obstacle_velocity")
    if n > 1:
        mux = builder.AddNamedSystem(
            "obstacle_velocities", Multiplexer([3 * count] * n)
        )
        builder.Connect(mux.get_output_port(0), target)
    for k in range(n):
        estimator = builder.AddNamedSystem(
            "velocity_estimator" if n == 1 else f"velocity_estimator_{k}",
            ObstacleVelocityEstimator(
                estimate.rate_hz, estimate.time_constant, estimate.gate, count
            ),
        )
        builder.Connect(states[k], estimator.GetInputPort("state"))
        builder.Connect(scenes[k], estimator.GetInputPort("obstacle"))
        builder.Connect(
            estimator.GetOutputPort("obstacle_velocity"),
            target if n == 1 else mux.get_input_port(k),
        )


def true_rows(
    builder: DiagramBuilder,
    faults: Faults,
    chain: FleetChain,
    states,
    scene_sensor: FleetSceneSensor | None,
) -> OutputPort:
    """The port of the rows to log: the chain's, or, where faults make the
    chain read other states or readings than the true ones (a lone
    vehicle's), `TrueRows`' with the truth put back."""
    rows = chain.GetOutputPort("rows")
    scene = scene_sensor is not None
    if not (estimate_faulted(faults) or (scene and readings_faulted(faults))):
        return rows
    truth = builder.AddNamedSystem("true_rows", TrueRows(scene, chain.readings))
    builder.Connect(rows, truth.GetInputPort("rows"))
    builder.Connect(states.get_output_port(0), truth.GetInputPort("states"))
    if scene:
        builder.Connect(
            scene_sensor.GetOutputPort("scene"), truth.GetInputPort("scene")
        )
    return truth.GetOutputPort("rows")


class OneIntegratorFleet:
    """The diagram of the module docstring and its handles."""

    def __init__(self, scenario: Scenario, method: "str | Method"):
        check_engine(scenario, [method])
        method = resolve_method(method)
        self.scenario, self.method = scenario, method.name
        self.vehicle = as_vehicle(scenario.vehicle)
        self.flown = vehicle_scenarios(scenario)
        n = len(self.flown)
        builder = DiagramBuilder()
        scene_graph = builder.AddNamedSystem("scene_graph", SceneGraph())
        # Moving obstacles: a lone vehicle's (`unsupported`).
        frames = add_obstacles(builder, scene_graph, scenario)
        self.plants = [
            builder.AddNamedSystem(f"quadrotor_{k}", make_plant(self.vehicle))
            for k in range(n)
        ]
        states = builder.AddNamedSystem("states", Multiplexer([STATE_SIZE] * n))
        for k, plant in enumerate(self.plants):
            builder.Connect(plant.get_output_port(0), states.get_input_port(k))
        scene = bool(scenario.obstacles) or scenario.ground is not None
        # Their velocities estimated from the readings, as `flight.chain.
        # navigator_of`'s `relative_navigator` does on the systems engine
        # (a user's field reads none).
        relative = bool(frames.frames) and uses_estimate(scenario, method)
        chain = builder.AddNamedSystem(
            "fleet_chain", chain_system(scenario, method, self.flown, scene, relative)
        )
        # Faults (a lone vehicle's, `unsupported`): the chain reads the state
        # estimate and the faulted readings, the plant the faulted rotors,
        # as the card's diagram does (`flight.chain.connect_controller`).
        faults = scenario.faults
        estimate_port = add_state_estimate(builder, faults, states.get_output_port(0))
        builder.Connect(estimate_port, chain.GetInputPort("states"))
        self.scene_sensor = None
        if scene:
            sensor = FleetSceneSensor(
                scenario.sensor.radius, n, bool(frames.frames), chain.readings
            )
            self.scene_sensor = builder.AddNamedSystem("scene_sensor", sensor)
            builder.Connect(
                scene_graph.get_query_output_port(),
                self.scene_sensor.GetInputPort("query"),
            )
            builder.Connect(
                states.get_output_port(0), self.scene_sensor.GetInputPort("states")
            )
            sensed = add_sensor_faults(
                builder, faults, self.scene_sensor.GetOutputPort("scene")
            )
            builder.Connect(sensed, chain.GetInputPort("scene"))
        if relative:
            add_velocity_estimators(
                builder, scenario.relative_velocity, n, estimate_port, sensed, chain
            )
        rotors = builder.AddNamedSystem("rotors", Demultiplexer(ROTORS * n, ROTORS))
        builder.Connect(
            add_rotor_faults(
                builder,
                faults,
                self.vehicle.hover_command,
                chain.GetOutputPort("rotor_forces"),
            ),
            rotors.get_input_port(0),
        )
        for k, plant in enumerate(self.plants):
            builder.Connect(
                rotors.get_output_port(k),
                add_rotor_path(builder, self.vehicle, plant.get_input_port(0), True),
            )
        rows = true_rows(builder, faults, chain, states, self.scene_sensor)
        # publish_period 0: the sink records once per integrator step.
        self.logger = LogVectorOutput(rows, builder, publish_period=0.0)
        self.logger.set_name("logger")
        self.chain, self.states = chain, states
        self.diagram = builder.Build()
        kind = "fleet" if n > 1 else "compiled"
        self.diagram.set_name(f"mfi_drake[{scenario.name}, {self.method}, {kind}]")
