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
      Simulator with the scenario's integrator.

Printed a row a (size, path): integrator steps, wall and CPU seconds per
simulated second, the CPU ratio to (a) in the same run, and the outcomes:
each vehicle's S (at its goal), C (collided with an obstacle) or - (still
flying at --seconds), the least separation between two vehicles, and
how far the vehicle farthest from where (a) left it ended.

What `add_navigation` lacks for (c), so that `add_vehicle` below builds
its pieces (`chain.add_sensor`, `add_controller`, `add_logger`) itself:
a second call on one builder adds systems of the same names ("sensor",
"navigator", ..., "logger"), and Drake's Build() aborts the process
("Non-unique name"); and a QuadrotorPlant vehicle has no geometry of its
own that its sensor would ignore (only a MultibodyPlant body's is), so its
own sphere would be its nearest obstacle. Seen through SceneGraph, the
other vehicles are moving geometry: their velocities are estimated from
the readings, as any moving obstacle's, the rule of the road (which
readings are vehicles) is lost, and `mfi`'s escape rule is off
(`methods.escape_off`): (c) flies the memoryless field, as
`add_navigation` does among moving geometry.

--profile N: cProfile of (c)'s flight at N vehicles, the 20 costliest
functions by own time.
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

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.flight.builder import add_rotor_path, apply_simulator_config
from mfi_drake.flight.chain import add_controller, add_logger, add_sensor, log_slices
from mfi_drake.flight.diagram import add_obstacles, make_plant, vehicle_scenarios
from mfi_drake.flight.result import Flight, fleet_flight
from mfi_drake.flight.simulation import simulate
from mfi_drake.flight.simulator import advance_timed
from mfi_drake.maths.layout import POSITION, STATE_SIZE
from mfi_drake.systems.sensors import VEHICLE_RGBA
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


def add_vehicle(builder, scene_graph, scenario: Scenario, plant, sphere, k: int):
    """`add_navigation`'s chain for vehicle k (its sensor ignoring its own
    sphere), every system it adds renamed "v{k}_NAME"; returns its logger."""
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
    controller = add_controller(
        builder, scenario, state, sensor, rotors, method=METHOD, moving=True
    )
    logger = add_logger(builder, state, sensor, controller)
    for system in builder.GetSystems():
        if id(system) not in before:
            system.set_name(f"v{k}_{system.get_name()}")
    return logger


def fly_drake_diagram(fleet: Scenario, profile: bool = False) -> Flight:
    """(c): the fleet as one Drake diagram, flown by one Simulator."""
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
    loggers = [
        add_vehicle(builder, scene_graph, s, p, q, k)
        for k, (s, p, q) in enumerate(zip(flown, plants, spheres, strict=True))
    ]
    diagram = builder.Build()
    simulator = Simulator(diagram)
    apply_simulator_config(fleet.simulator, simulator)
    context = simulator.get_mutable_context()
    for plant, s in zip(plants, flown, strict=True):
        x0 = np.zeros(STATE_SIZE)
        x0[POSITION] = s.start
        plant.GetMyMutableContextFromRoot(context).SetContinuousState(x0)
    profiler = cProfile.Profile() if profile else None
    if profiler:
        profiler.enable()
    run = advance_timed(simulator, fleet.duration)
    if profiler:
        profiler.disable()
        pstats.Stats(profiler).sort_stats("tottime").print_stats(20)
    integrator = simulator.get_integrator()
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
                log={name: data[:, sl] for name, sl in log_slices().items()},
                wall_time=run.wall_time,
                cpu_time=run.cpu_time,
                integrator_steps=integrator.get_num_steps_taken(),
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
    parser.add_argument("--paths", default="a,b,c")
    parser.add_argument("--profile", type=int, default=0)
    args = parser.parse_args()
    field = generator.random_field(args.field_seed, 0, 0.1)
    if args.profile:
        fleet = random_pairs(field, args.profile, args.field_seed, 0)
        fly_drake_diagram(replace(fleet, duration=args.seconds), profile=True)
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
            row(n, "(c) one Drake diagram", fly_drake_diagram(fleet), reference)


if __name__ == "__main__":
    main()
