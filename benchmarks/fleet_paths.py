"""One fleet, three ways to fly it (docs/fleets.md, "One fleet path?").

    python benchmarks/fleet_paths.py [--sizes 8,16,32] [--seconds 8]
                                     [--field-seed 0] [--profile N]

The same fleet (`random_pairs` on the multi-vehicle sweep's field 0 of
--field-seed at density 0.1, MFI, the first --seconds of its flight) is
flown at each size by:

  (a) one integrator, the compiled FleetChain (`fleet_integration: one`),
      today's fastest path;
  (b) separate integration: a diagram and Simulator a vehicle, states
      exchanged at `exchange_hz` (`fleet_integration: separate`, one
      process);
  (c) one Drake diagram a Drake user would build: on one DiagramBuilder
      and one SceneGraph, N QuadrotorPlants, each registered in SceneGraph
      as its collision sphere (`VehicleSphere`) so that the others' sensors
      see it, each with the chain `add_navigation` adds, flown by one
      Simulator with the scenario's integrator;
  (d) as (c), each vehicle's chain the compiled one (`FleetChain` of one
      vehicle, what `engine: compiled` flies alone) in place of the
      LeafSystems `add_navigation` adds: one Python system a vehicle for the
      chain and one for its sensor, as a compiled `add_navigation` would add.

Printed a row a (size, path): integrator steps, wall and CPU seconds per
simulated second, the CPU ratio to (a) in the same run, and the outcomes:
each vehicle's S (at its goal), C (collided with an obstacle) or - (still
flying at --seconds), the least separation between two vehicles, and
how far the vehicle farthest from where (a) left it ended.

What `add_navigation` lacks for (c), so that `add_vehicle` below builds
its pieces (`chain.add_sensor`, `add_controller`, `add_logger`) itself:
a QuadrotorPlant vehicle has no geometry of its
own that its sensor would ignore (only a MultibodyPlant body's is), so its
own sphere would be its nearest obstacle. Seen through SceneGraph, the
other vehicles are moving geometry: their velocities are estimated from
the readings, as any moving obstacle's, the rule of the road (which
readings are vehicles) is lost, and `mfi`'s escape rule is off among
moving geometry (`config.navigation.NavigationConfig.moving_obstacles`).
Every path flies `mfi-memoryless`, which is what `mfi` flies there.

--profile N: cProfile of (c)'s flight at N vehicles (with --paths d,
(d)'s), the 20 costliest functions by own time, and the systems' calcs by
cumulative time.

--overhead: what a Python LeafSystem a vehicle costs by itself: N systems
of x' = u − x (12 states each, u from a constant source) against one
system of the N × 12 states, each flown 20 s by the default integrator;
printed: CPU µs per vehicle and derivative evaluation.
"""

import argparse
import cProfile
import pstats
import time
from dataclasses import replace

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    RenderLabel,
    SceneGraph,
)
from pydrake.geometry import Sphere as DrakeSphere
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from mfi_drake.config.navigation import navigation_config
from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.flight.builder import (
    add_rotor_path,
    apply_simulator_config,
    place_quadrotor,
)
from mfi_drake.flight.chain import (
    add_controller,
    add_logger,
    add_sensor,
    log_slices,
    named_apart,
    own_geometry,
)
from mfi_drake.flight.diagram import add_obstacles, make_plant, vehicle_scenarios
from mfi_drake.flight.fleet import add_velocity_estimators, chain_system, uses_estimate
from mfi_drake.flight.methods import resolve_method
from mfi_drake.flight.result import Flight, fleet_flight
from mfi_drake.flight.simulation import simulate
from mfi_drake.flight.simulator import advance_timed
from mfi_drake.maths.fleet import row_slices
from mfi_drake.maths.layout import POSITION, STATE_SIZE
from mfi_drake.systems.sensors import VEHICLE_RGBA
from mfi_drake.systems.sensors import SphereSensor as SphereSensorSystem
from mfi_drake.world import generator
from mfi_drake.world.fleets import random_pairs
from mfi_drake.world.obstacles import sensed

METHOD = "mfi-memoryless"  # what (c) flies: see the module docstring


class VehicleSphere(LeafSystem):
    """A vehicle's collision sphere in SceneGraph, posed from its state:
    what the other vehicles' sensors read."""

    def __init__(self, scene_graph: SceneGraph, radius: float, name: str):
        super().__init__()
        self.source_id = scene_graph.RegisterSource(name)
        self.frame_id = scene_graph.RegisterFrame(self.source_id, GeometryFrame(name))
        sphere = GeometryInstance(RigidTransform(), DrakeSphere(radius), name)
        sensed(sphere, VEHICLE_RGBA, RenderLabel.kDontCare)
        scene_graph.RegisterGeometry(self.source_id, self.frame_id, sphere)
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self.DeclareAbstractOutputPort(
            "geometry_pose",
            lambda: AbstractValue.Make(FramePoseVector()),
            self._calc,
            prerequisites_of_calc={self._state.ticket()},
        )

    def _calc(self, context, output):
        p = self._state.Eval(context)[POSITION]
        output.get_mutable_value().set_value(self.frame_id, RigidTransform(p))


def add_vehicle(builder, scene_graph, scenario: Scenario, plant, sphere):
    """`add_navigation`'s chain for a vehicle (its sensor ignoring its own
    sphere), its systems named apart from the others' (`named_apart`);
    returns its logger."""
    before = set(map(id, builder.GetSystems()))
    vehicle = as_vehicle(scenario.vehicle)
    state = plant.get_output_port(0)
    sensor = add_sensor(
        builder,
        scenario.sensor,
        scene_graph,
        state,
        vehicle=vehicle,
        moving=True,
        ignore=(sphere.frame_id,),
    )
    rotors = add_rotor_path(builder, vehicle, plant.get_input_port(0), True)
    # Seen through SceneGraph the other vehicles are moving obstacles.
    config = replace(navigation_config(scenario, METHOD), moving_obstacles=True)
    controller = add_controller(builder, config, state, sensor, rotors, method=METHOD)
    logger = add_logger(builder, state, sensor, controller)
    named_apart(builder, before)
    return logger


class Decay(LeafSystem):
    """x' = u − x: a LeafSystem's call and nothing else (--overhead)."""

    def __init__(self, size: int):
        super().__init__()
        self.DeclareContinuousState(size)
        self._u = self.DeclareVectorInputPort("u", size)

    def DoCalcTimeDerivatives(self, context, derivatives):
        x = context.get_continuous_state_vector().CopyToVector()
        derivatives.get_mutable_vector().SetFromVector(self._u.Eval(context) - x)


def overhead(n: int, systems: int) -> float:
    """CPU µs per vehicle and derivative evaluation of n vehicles' Decay in
    `systems` LeafSystems (1 or n)."""
    builder = DiagramBuilder()
    for _ in range(systems):
        size = STATE_SIZE * n // systems
        decay = builder.AddSystem(Decay(size))
        source = builder.AddSystem(ConstantVectorSource(np.ones(size)))
        builder.Connect(source.get_output_port(), decay.get_input_port())
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    start = time.process_time()
    simulator.AdvanceTo(20.0)
    cpu = time.process_time() - start
    return 1e6 * cpu / simulator.get_integrator().get_num_derivative_evaluations() / n


def add_compiled_vehicle(builder, scene_graph, scenario, plant, sphere):
    """(d)'s vehicle: its sphere sensor (ignoring its own sphere) and the
    compiled chain of one vehicle, its systems named apart from the
    others' (`named_apart`); returns the logger of the chain's row."""
    before = set(map(id, builder.GetSystems()))
    method = resolve_method(METHOD)
    vehicle = as_vehicle(scenario.vehicle)
    state = plant.get_output_port(0)
    sensor = builder.AddNamedSystem(
        "sensor",
        SphereSensorSystem(
            scenario.sensor.radius,
            moving=True,
            ignore=own_geometry(scene_graph, (sphere.frame_id,)),
        ),
    )
    builder.Connect(scene_graph.get_query_output_port(), sensor.GetInputPort("query"))
    builder.Connect(state, sensor.GetInputPort("state"))
    relative = uses_estimate(scenario, method)
    chain = builder.AddNamedSystem(
        "chain", chain_system(scenario, method, [scenario], True, relative)
    )
    builder.Connect(state, chain.GetInputPort("states"))
    builder.Connect(sensor.GetOutputPort("obstacle"), chain.GetInputPort("scene"))
    if relative:
        estimate = scenario.relative_velocity
        obstacle = sensor.GetOutputPort("obstacle")
        add_velocity_estimators(builder, estimate, 1, state, obstacle, chain)
    builder.Connect(
        chain.GetOutputPort("rotor_forces"),
        add_rotor_path(builder, vehicle, plant.get_input_port(0), True),
    )
    logger = LogVectorOutput(chain.GetOutputPort("rows"), builder, 0.0)
    named_apart(builder, before)
    return logger


def fly_drake_diagram(fleet: Scenario, compiled: bool, profile: bool = False):
    """(c), or (d) where `compiled`: the fleet as one Drake diagram, flown
    by one Simulator."""
    flown = [replace(s, other_vehicles=[]) for s in vehicle_scenarios(fleet)]
    vehicle = as_vehicle(fleet.vehicle)
    builder = DiagramBuilder()
    scene_graph = builder.AddNamedSystem("scene_graph", SceneGraph())
    add_obstacles(builder, scene_graph, fleet)
    plants, spheres = [], []
    for k in range(len(flown)):  # every sphere first: each sensor sees them all
        plant = builder.AddNamedSystem(f"quadrotor_{k}", make_plant(vehicle))
        sphere = builder.AddNamedSystem(
            f"sphere_{k}",
            VehicleSphere(scene_graph, vehicle.collision_radius, f"vehicle_{k}"),
        )
        builder.Connect(plant.get_output_port(0), sphere.get_input_port(0))
        builder.Connect(
            sphere.get_output_port(0),
            scene_graph.get_source_pose_port(sphere.source_id),
        )
        plants.append(plant)
        spheres.append(sphere)
    add = add_compiled_vehicle if compiled else add_vehicle
    loggers = [
        add(builder, scene_graph, s, p, q)
        for s, p, q in zip(flown, plants, spheres, strict=True)
    ]
    simulator = Simulator(builder.Build())
    apply_simulator_config(fleet.simulator, simulator)
    context = simulator.get_mutable_context()
    for plant, s in zip(plants, flown, strict=True):
        place_quadrotor(plant, context, s.start)
    profiler = cProfile.Profile() if profile else None
    if profiler:
        profiler.enable()
    run = advance_timed(simulator, fleet.duration)
    if profiler:
        profiler.disable()
        stats = pstats.Stats(profiler)
        stats.sort_stats("tottime").print_stats(20)
        # Each system's share: its calcs' cumulative time.
        stats.sort_stats("cumulative").print_stats(r"systems/|fleet_paths", 20)
    slices = row_slices() if compiled else log_slices()
    flights = []
    for s, logger in zip(flown, loggers, strict=True):
        log = logger.FindLog(context)
        data = log.data().T
        flights.append(
            Flight(
                scenario=s,
                method=METHOD,
                sensor="sphere",
                collision_radius=vehicle.collision_radius,
                times=log.sample_times().copy(),
                log={name: data[:, sl] for name, sl in slices.items()},
                wall_time=run.wall_time,
                cpu_time=run.cpu_time,
                integrator_steps=simulator.get_integrator().get_num_steps_taken(),
            )
        )
    return fleet_flight(flights)


def outcomes(flight: Flight) -> str:
    """Each vehicle's S, C or - (module docstring), and the least
    separation."""
    marks = "".join(
        "C" if v["collided"] else "S" if v["reached"] else "-"
        for v in flight.metrics["vehicles"]
    )
    return f"{marks} {flight.metrics['min_separation']:.3f}"


def ends(flight: Flight) -> np.ndarray:
    """(N, 3): each vehicle's last logged position."""
    return np.array([f.positions[-1] for f in (flight, *flight.others)])


def row(n: int, path: str, flight: Flight, reference: Flight | None) -> None:
    """Prints `flight`'s row, its CPU and its ends against `reference`'s."""
    sim = flight.metrics["sim_time"]
    cpu, wall = flight.cpu_time / sim, flight.wall_time / sim
    steps = np.mean([f.integrator_steps for f in (flight, *flight.others)])
    ratio, apart = "–", "–"
    if reference is not None:
        ratio = f"{cpu / (reference.cpu_time / reference.metrics['sim_time']):.2f}"
        gaps = np.linalg.norm(ends(flight) - ends(reference), axis=1)
        apart = f"{gaps.max():.3f}"
    print(
        f"| {n} | {path} | {steps:.0f} | {wall:.2f} | {cpu:.2f} | {ratio} "
        f"| {outcomes(flight)} | {apart} |",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", default="8,16,32")
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--field-seed", type=int, default=0)
    parser.add_argument("--paths", default="a,b,c,d")
    parser.add_argument("--profile", type=int, default=0)
    parser.add_argument("--overhead", action="store_true")
    args = parser.parse_args()
    if args.overhead:
        for n in (8, 16, 32):
            print(
                f"{n} vehicles: a LeafSystem each {overhead(n, n):.1f} µs, "
                f"one for all {overhead(n, 1):.1f} µs a vehicle and evaluation"
            )
        return
    field = generator.random_field(args.field_seed, 0, 0.1)
    if args.profile:
        fleet = random_pairs(field, args.profile, args.field_seed, 0)
        flown = replace(fleet, duration=args.seconds)
        fly_drake_diagram(flown, args.paths == "d", profile=True)
        return
    paths = args.paths.split(",")
    print(
        f"field {args.field_seed}/0 at 0.1, {len(field.obstacles)} obstacles, "
        f"{METHOD}, {args.seconds} s"
    )
    print(
        "| N | path | steps (a vehicle's) | wall s per sim s | CPU s per sim s "
        "| CPU ratio to (a) | outcomes, least separation [m] "
        "| largest distance from (a)'s end [m] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for n in [int(s) for s in args.sizes.split(",")]:
        fleet = replace(
            random_pairs(field, n, args.field_seed, 0), duration=args.seconds
        )
        reference = None
        if "a" in paths:
            start = time.perf_counter()
            one = simulate(replace(fleet, fleet_integration="one"), METHOD)
            build = time.perf_counter() - start - one.wall_time
            row(n, f"(a) one integrator (build {build:.1f} s)", one, one)
            reference = one
        if "b" in paths:
            separate = simulate(replace(fleet, fleet_integration="separate"), METHOD)
            row(n, "(b) separate", separate, reference)
        if "c" in paths:
            row(n, "(c) one Drake diagram", fly_drake_diagram(fleet, False), reference)
        if "d" in paths:
            flight = fly_drake_diagram(fleet, True)
            row(n, "(d) (c), compiled chains", flight, reference)


if __name__ == "__main__":
    main()
