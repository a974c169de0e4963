"""MFI navigation in a user's own Drake diagram:

    from mfi_drake import (add_navigation, apply_simulator_config,
                           default_simulator_config)

    handles = add_navigation(builder, plant=quadrotor, scene_graph=scene_graph,
                             goal=[12.0, 0.0, 1.5])
    diagram = builder.Build()
    simulator = Simulator(diagram)
    apply_simulator_config(default_simulator_config(), simulator)
    handles.set_start(simulator.get_mutable_context(), [0.0, 0.0, 1.5])
    simulator.AdvanceTo(30.0)

`add_navigation` is `flight.chain`'s pieces around the user's plant:
`add_sensor`, `add_controller` and `add_logger`, configured by a
`NavigationConfig` (or keywords naming its fields). Every proximity
geometry of the SceneGraph is an obstacle, whoever registered it; the
vehicle's own never is. `flight.diagram.build_diagram` builds a scenario's
diagram with it too (the scenario's `navigation_config`), so a scenario's
flight and a user's flight of the same scene are the same computation.
"""

from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace

import numpy as np
from pydrake.examples import QuadrotorPlant
from pydrake.geometry import GeometryId, SceneGraph
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import RigidBody
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import (
    Context,
    DiagramBuilder,
    InputPort,
    LeafSystem,
    OutputPort,
)
from pydrake.systems.primitives import MatrixGain, VectorLogSink

from mfi_drake.config.faults import Faults
from mfi_drake.config.navigation import NavigationConfig, check_navigation
from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.scenario import ScenarioError, Sensor, SphereSensor
from mfi_drake.config.vehicles import Vehicle, VehicleError, as_vehicle
from mfi_drake.flight.chain import (
    CameraMount,
    Controller,
    add_controller,
    add_logger,
    add_sensor,
    log_slices,
    named_apart,
    own_geometry,
    readings_of,
)
from mfi_drake.flight.methods import Method, MethodError, resolve_method
from mfi_drake.flight.scene import goal_obstacle, scene_moves
from mfi_drake.maths.layout import POSITION, STATE_SIZE
from mfi_drake.maths.quadcopter import plus_commands
from mfi_drake.systems.multibody import add_propellers, add_vehicle_state, place_vehicle
from mfi_drake.systems.rotors import motor_lag

WITNESS_SCALE = 0.01  # Drake's witness isolation window over the context's accuracy


class BuilderError(ScenarioError):
    """An argument of the builder API that cannot be flown; the message is
    one line naming the argument and its value (a ScenarioError, so the
    CLI's exit status 2)."""


def apply_simulator_config(config: SimulatorConfig, simulator: Simulator) -> None:
    """Drake's `ApplySimulatorConfig`, and the context's accuracy that eq
    21's witness functions need (without it Drake's witness isolation
    raises "accuracy is not set in the context").

    The integrator's accuracy is set by the config. The context's is what
    witness isolation reads: Drake locates a witness's zero (eq 21's mode
    switches) to within WITNESS_SCALE × that accuracy × 1 s. Set so that a
    switch is located to the integrator's accuracy in seconds (1e-4 s at
    the default), not 100 times finer: on the paper scenarios that is 3–9 %
    fewer steps, path lengths within 1e-4 m, convergence times within 6 ms."""
    ApplySimulatorConfig(config, simulator)
    simulator.get_mutable_context().SetAccuracy(
        min(1.0, config.accuracy / WITNESS_SCALE)
    )


@dataclass
class NavigationHandles(Controller):
    """What `add_navigation` added (the `Controller`'s systems and more), and
    how to start and read a flight."""

    config: NavigationConfig  # as flown: its vehicle, its method's name
    sensor: LeafSystem  # its output "obstacle" is what the navigator reads
    logger: VectorLogSink  # LOG_LAYOUT, once per integrator step
    state: OutputPort  # the vehicle's true 12-vector state the chain reads
    rotor_command: InputPort  # the 4 rotor forces the mixer drives
    vehicle: Vehicle
    body: RigidBody | None  # a MultibodyPlant vehicle's floating body
    ignored: frozenset[GeometryId]  # never seen as obstacles: the vehicle's own
    place: Callable[[Context, np.ndarray], None] = field(repr=False)

    def set_start(self, root_context: Context, position) -> None:
        """Puts the vehicle at `position` [m], level and at rest, in the
        diagram's `root_context`."""
        self.place(root_context, _point("position", position))

    def log_slices(self) -> dict[str, slice]:
        return log_slices(readings_of(self.sensor))

    def read_log(self, root_context: Context) -> tuple[np.ndarray, dict]:
        """(times, {signal name: (N, size) array}) logged so far."""
        log = self.logger.FindLog(root_context)
        data = log.data().T
        return log.sample_times().copy(), {
            name: data[:, s] for name, s in self.log_slices().items()
        }


def add_navigation(
    builder: DiagramBuilder,
    plant: QuadrotorPlant | MultibodyPlant,
    scene_graph: SceneGraph,
    goal=None,
    *,
    config: NavigationConfig | None = None,
    body: str | RigidBody | None = None,
    method: "str | Callable | Method | None" = None,
    vehicle: "str | Vehicle | None" = None,
    sensor: Sensor | None = None,
    navigator: NavigatorParams | dict | None = None,
    faults: Faults | None = None,
    check_goal: bool = True,
    map_points: np.ndarray | None = None,
) -> NavigationHandles:
    """Adds MFI navigation (or `method`'s) to `builder`: a sensor reading
    `scene_graph`, the navigator, the goal attraction, eq 25's attitude PD
    and the mixer, from `plant`'s state to its rotor forces, and a logger
    of LOG_LAYOUT; returns their handles.

    `plant`: Drake's QuadrotorPlant in `builder`, or a finalized
    MultibodyPlant with `body`, the vehicle's floating body (its name or
    the RigidBody), driven by Drake's Propeller; the body's own mass and
    inertia replace the vehicle's (`body_vehicle`). `scene_graph`: the
    SceneGraph in `builder`; every proximity geometry in it is an obstacle
    but the vehicle's own (on `body`'s frame).

    What to fly: `config`, a `NavigationConfig` (Drake's `Apply*Config`
    idiom), or keywords naming its fields: `goal` [x, y, z] (m), `method`
    (default "mfi"; a name, "MODULE:NAME" of a user's field, or the
    function), `vehicle` (a preset's name or a `Vehicle`; default
    "drake_default"), `sensor`, `navigator` (NavigatorParams, or a dict of
    its fields) and `faults`. Beside `config` only `method` may be given
    (a function or a `Method`, which a config's string cannot hold).

    `check_goal`: refuse a goal where the vehicle would touch an obstacle
    (`_check_goal`). `map_points` (n, 3): a point-cloud map the sensor
    reads instead of `scene_graph` (`add_sensor`).

    A plain Simulator also needs `apply_simulator_config` (eq 21's
    witnesses read the context's accuracy), then `handles.set_start`.
    Raises BuilderError naming the first bad argument, adding nothing."""
    keywords = {"goal": goal, "vehicle": vehicle, "sensor": sensor}
    keywords |= {"navigator": navigator, "faults": faults}
    config, resolved = _checked_config(config, method, keywords)
    before = {id(system) for system in builder.GetSystems()}
    rig = _vehicle(builder, plant, body, scene_graph, config)
    config = replace(config, vehicle=rig.vehicle)
    if check_goal:
        _check_goal(builder, scene_graph, config.goal, rig.vehicle, rig.ignored)
    rig.connect()  # nothing is added to builder before every check has passed
    moving = config.moving_obstacles or scene_moves(builder, scene_graph, rig.ignored)
    config = replace(config, moving_obstacles=moving)
    sensor = add_sensor(
        builder,
        config.sensor,
        scene_graph,
        rig.state,
        vehicle=rig.vehicle,
        other_vehicles=config.other_vehicles,
        moving=moving,
        ignore=rig.ignored,
        mount=rig.mount,
        map_points=map_points,
    )
    controller = add_controller(
        builder, config, rig.state, sensor, rig.rotor_command, method=resolved
    )
    logger = add_logger(builder, rig.state, sensor, controller)
    named_apart(builder, before)
    return NavigationHandles(
        **vars(controller),
        config=config,
        sensor=sensor,
        logger=logger,
        state=rig.state,
        rotor_command=rig.rotor_command,
        vehicle=rig.vehicle,
        body=rig.body,
        ignored=rig.ignored,
        place=rig.place,
    )


def _checked_config(
    config: NavigationConfig | None, method, keywords: dict
) -> tuple[NavigationConfig, Method]:
    """`config`, or the config of `add_navigation`'s `keywords` where it is
    None, and its method (`method` where given), resolved and checked;
    raises BuilderError naming the first bad argument."""
    if config is None:
        config = _keyword_config(**keywords)
    else:
        for name, value in keywords.items():
            if value is not None:
                raise BuilderError(
                    f"{name} = {value!r}: given with config; set config.{name}"
                )
    try:
        resolved = resolve_method(config.method if method is None else method)
    except MethodError as e:
        raise BuilderError(f"method = {method or config.method!r}: {e}") from None
    config = replace(config, method=resolved.name)
    try:
        check_navigation(config, "add_navigation")
        as_vehicle(config.vehicle)
    except (ScenarioError, VehicleError) as e:
        raise BuilderError(str(e)) from None
    return config, resolved


def _keyword_config(
    goal,
    vehicle: "str | Vehicle | None",
    sensor: Sensor | None,
    navigator: NavigatorParams | dict | None,
    faults: Faults | None,
) -> NavigationConfig:
    """The NavigationConfig of `add_navigation`'s keywords, the others at
    their defaults; raises BuilderError naming a keyword of a wrong type."""
    if faults is not None and not isinstance(faults, Faults):
        raise BuilderError(f"faults = {faults!r}: must be a Faults")
    return NavigationConfig(
        goal=_point("goal", goal).tolist(),
        vehicle="drake_default" if vehicle is None else vehicle,
        sensor=SphereSensor() if sensor is None else sensor,
        navigator=_navigator_params(navigator),
        faults=Faults() if faults is None else faults,
    )


def _check_goal(builder, scene_graph, goal, vehicle: Vehicle, ignored) -> None:
    """Raises BuilderError where the vehicle at `goal` would touch geometry
    whose pose is known at build time: anchored geometry, and a finalized
    MultibodyPlant's at its default context (exact for welded bodies; free
    bodies where they are by default); geometry another source moves is
    not checked."""
    touched = goal_obstacle(
        builder, scene_graph, goal, vehicle.collision_radius, ignored
    )
    if touched:
        raise BuilderError(
            f"goal = {goal}: the vehicle there (collision radius "
            f"{vehicle.collision_radius} m) would touch the obstacle "
            f"{touched[0]!r} (distance {touched[1]:.3f} m)"
        )


def _point(name: str, value) -> np.ndarray:
    try:
        point = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        point = None
    if point is None or point.shape != (3,) or not np.isfinite(point).all():
        raise BuilderError(
            f"{name} = {value!r}: must be 3 finite numbers [x, y, z] (m)"
        )
    return point


def _navigator_params(navigator) -> NavigatorParams:
    if navigator is None:
        return NavigatorParams()
    if isinstance(navigator, NavigatorParams):
        return replace(navigator)
    if not isinstance(navigator, dict):
        raise BuilderError(
            f"navigator = {navigator!r}: must be a NavigatorParams or a dict of "
            "its fields"
        )
    known = {f.name for f in fields(NavigatorParams)}
    for key, value in navigator.items():
        if key not in known:
            raise BuilderError(
                f"navigator.{key} = {value!r}: unknown field of NavigatorParams"
            )
    return replace(NavigatorParams(), **navigator)


@dataclass
class _Rig:
    """How the chain meets a plant: its state and rotor ports (once
    `connect` has added what they need), its own geometry, where cameras
    ride and how it is placed at a start."""

    vehicle: Vehicle  # a MultibodyPlant body's own mass and inertia
    ignored: frozenset[GeometryId]  # its own geometry, no obstacle
    mount: CameraMount | None
    place: Callable[[Context, np.ndarray], None]
    add_ports: Callable[[], tuple[OutputPort, InputPort]]
    body: RigidBody | None = None
    state: OutputPort | None = None
    rotor_command: InputPort | None = None

    def connect(self) -> None:
        self.state, self.rotor_command = self.add_ports()


def _check_added(builder: DiagramBuilder, name: str, system, kind) -> None:
    if not isinstance(system, kind):
        raise BuilderError(
            f"{name} = {type(system).__name__}: must be a {kind.__name__}"
        )
    if not any(s is system for s in builder.GetSystems()):
        raise BuilderError(f"{name} = {system.get_name()!r}: is not in builder")


def _vehicle(builder, plant, body, scene_graph, config: NavigationConfig) -> _Rig:
    _check_added(builder, "scene_graph", scene_graph, SceneGraph)
    if isinstance(plant, QuadrotorPlant):
        _check_added(builder, "plant", plant, QuadrotorPlant)
        if body is not None:
            raise BuilderError(f"body = {body!r}: only a MultibodyPlant has bodies")
        vehicle = as_vehicle(config.vehicle)
        return _Rig(
            vehicle=vehicle,
            ignored=frozenset(),
            mount=None,
            place=lambda context, p: place_quadrotor(plant, context, p),
            add_ports=lambda: (
                plant.get_output_port(0),
                add_rotor_path(builder, vehicle, plant.get_input_port(0), True),
            ),
        )
    if isinstance(plant, MultibodyPlant):
        _check_added(builder, "plant", plant, MultibodyPlant)
        return _multibody_vehicle(builder, plant, body, scene_graph, config)
    raise BuilderError(
        f"plant = {type(plant).__name__}: must be a QuadrotorPlant or a MultibodyPlant"
    )


def place_quadrotor(plant: QuadrotorPlant, root_context: Context, position) -> None:
    """Puts `plant`, a subsystem of the diagram of `root_context`, at
    `position`, level and at rest."""
    x0 = np.zeros(STATE_SIZE)
    x0[POSITION] = position
    plant.GetMyMutableContextFromRoot(root_context).SetContinuousState(x0)


def _multibody_vehicle(builder, plant, body, scene_graph, config) -> _Rig:
    """The MultibodyPlant vehicle: its `body`'s pose and velocity as
    QuadrotorPlant's state, Drake's Propellers on it (`systems.multibody`)."""
    if not plant.is_finalized():
        raise BuilderError(
            f"plant = {plant.get_name()!r}: a MultibodyPlant must be finalized "
            "before add_navigation"
        )
    rigid = _floating_body(plant, body)
    vehicle = body_vehicle(as_vehicle(config.vehicle), rigid)
    own, mount = (), None
    if (
        plant.geometry_source_is_registered()
        and scene_graph.model_inspector().SourceIsRegistered(plant.get_source_id())
    ):
        frame = plant.GetBodyFrameIdOrThrow(rigid.index())
        own = (frame,)
        mount = CameraMount(frame, plant.get_geometry_pose_output_port())
    elif not isinstance(config.sensor, SphereSensor):
        raise BuilderError(
            f"plant = {plant.get_name()!r}: cameras need the vehicle in "
            "scene_graph (register the plant with it)"
        )

    def add_ports() -> tuple[OutputPort, InputPort]:
        state = add_vehicle_state(builder, plant, rigid)
        propeller = add_propellers(builder, plant, rigid, vehicle)
        command = propeller.get_command_input_port()
        return state.GetOutputPort("state"), add_rotor_path(
            builder, vehicle, command, False
        )

    def place(context: Context, position: np.ndarray) -> None:
        place_vehicle(
            plant, plant.GetMyMutableContextFromRoot(context), rigid, position
        )

    ignored = own_geometry(scene_graph, own)
    return _Rig(vehicle, ignored, mount, place, add_ports, body=rigid)


def body_vehicle(vehicle: Vehicle, body: RigidBody) -> Vehicle:
    """`vehicle` (its rotors and size) with `body`'s own mass and principal
    moments of inertia about its centre of mass (the diagonal of its
    rotational inertia in its frame: the rotors' frame); `vehicle` itself
    where they agree to 1e-9 (Drake stores a body's inertia per unit
    mass, so a model written from the record reads back within ulps). Raises
    BuilderError where the body's mass leaves too little thrust."""
    inertia = body.default_spatial_inertia()
    central = inertia.Shift(inertia.get_com()).CalcRotationalInertia()
    moments = central.CopyToFullMatrix3().diagonal()
    same = np.allclose(
        [body.default_mass(), *moments],
        [vehicle.mass, *vehicle.inertia],
        rtol=1e-9,
        atol=0,
    )
    if same:  # the vehicle's own model: its record's numbers, not Drake's rounding
        return vehicle
    try:
        return as_vehicle(
            replace(
                vehicle,
                mass=body.default_mass(),
                inertia=[float(m) for m in moments],
            ),
            f"body {body.name()!r}'s vehicle",
        )
    except VehicleError as e:
        raise BuilderError(str(e)) from None


def add_rotor_path(
    builder: DiagramBuilder, vehicle: Vehicle, rotors: InputPort, to_plus: bool
) -> InputPort:
    """The input that drives `rotors` (a plant's rotor commands) with the
    vehicle's own commands: through its motors' first-order lag
    (`systems.rotors.motor_lag`, where motor_time_constant > 0) and, for Drake's "+"
    QuadrotorPlant (`to_plus`) flying an "x" vehicle, through the map to
    the "+" commands of the same wrench (`quadcopter.plus_commands`).
    `rotors` itself where neither applies."""
    if to_plus and vehicle.layout != "+":
        gain = builder.AddSystem(MatrixGain(plus_commands(vehicle)))
        builder.Connect(gain.get_output_port(), rotors)
        rotors = gain.get_input_port()
    if vehicle.motor_time_constant > 0.0:
        lag = builder.AddSystem(
            motor_lag(vehicle.motor_time_constant, vehicle.hover_command)
        )
        builder.Connect(lag.get_output_port(), rotors)
        rotors = lag.get_input_port()
    return rotors


def _floating_body(plant: MultibodyPlant, body) -> RigidBody:
    if body is None:
        raise BuilderError(
            "body: missing; a MultibodyPlant vehicle needs body='NAME', its "
            "floating body"
        )
    if isinstance(body, RigidBody):
        rigid = body
    elif not isinstance(body, str) or not plant.HasBodyNamed(body):
        raise BuilderError(f"body = {body!r}: no body of that name in plant")
    else:
        try:
            rigid = plant.GetBodyByName(body)
        except RuntimeError:
            raise BuilderError(
                f"body = {body!r}: several model instances have one; pass the RigidBody"
            ) from None
    if not rigid.is_floating_base_body():
        raise BuilderError(f"body = {rigid.name()!r}: is not a floating body")
    return rigid
