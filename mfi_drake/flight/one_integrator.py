"""A fleet flown on one integrator (`fleet_integration: one`; the diagram is
`flight.fleet.OneIntegratorFleet`, docs/fleets.md): `fly_one_integrator`,
with `one_integrator_monitor` ending the flight at a contact or once every
vehicle has settled."""

from dataclasses import replace

from pydrake.systems.framework import EventStatus

from mfi_drake.config.scenario import Scenario
from mfi_drake.flight.builder import place_quadrotor
from mfi_drake.flight.fleet import OneIntegratorFleet
from mfi_drake.flight.methods import Method
from mfi_drake.flight.monitors import (
    CONTACT_MARGIN,
    RestClock,
    centre_gap,
    in_contact,
    settles,
)
from mfi_drake.flight.result import Flight, fleet_flight
from mfi_drake.flight.simulator import (
    advance_timed,
    ended_trapped,
    simulator_at_start,
)
from mfi_drake.maths.fleet import row_size, row_slices
from mfi_drake.maths.layout import POSITION, STATE_SIZE


def one_integrator_monitor(
    fleet: OneIntegratorFleet, until_settled: bool, stop_at_contact: bool
):
    """A Simulator monitor: ends the flight at a contact (two vehicles'
    spheres, or a scene sensor's reading, closer than the collision
    radius) with `stop_at_contact`, and once every vehicle has rested at
    its goal for SETTLE_HOLD (`monitors.settled_monitor`'s test) with
    `until_settled`."""
    radius = fleet.vehicle.collision_radius
    n = len(fleet.flown)
    clock = RestClock([s.goal for s in fleet.flown], fleet.scenario.simulator.accuracy)

    def monitor(context) -> EventStatus:
        states = fleet.states.get_output_port(0).Eval(
            fleet.states.GetMyContextFromRoot(context)
        )
        x = states.reshape(n, STATE_SIZE)
        if stop_at_contact:
            if n > 1 and centre_gap(x[:, POSITION]) < 2.0 * radius - CONTACT_MARGIN:
                return EventStatus.ReachedTermination(fleet.chain, "vehicles touch")
            sensor = fleet.scene_sensor
            if sensor is not None:
                port = sensor.get_output_port(0)
                scene = port.Eval(sensor.GetMyContextFromRoot(context))
                for reading in scene.reshape(n, -1):
                    if in_contact(reading, radius):
                        return EventStatus.ReachedTermination(sensor, "in contact")
        if until_settled and clock.settled(context.get_time(), x):
            return EventStatus.ReachedTermination(fleet.chain, "every vehicle settled")
        return EventStatus.Succeeded()

    return monitor


def fly_one_integrator(
    scenario: Scenario,
    method: "str | Method" = "mfi",
    until_settled: bool = False,
    stop_at_contact: bool = False,
) -> Flight:
    """Flies a fleet, or a lone vehicle on the compiled engine, on one
    integrator (`OneIntegratorFleet`). Returns the first vehicle's Flight
    with the others in `others`, each with the single-vehicle log layout;
    wall and CPU times are the fleet's."""
    fleet_diagram = OneIntegratorFleet(scenario, method)
    simulator = simulator_at_start(
        fleet_diagram.diagram, fleet_diagram.plants[0], scenario
    )
    context = simulator.get_mutable_context()
    for plant, flown in zip(
        fleet_diagram.plants[1:], fleet_diagram.flown[1:], strict=True
    ):
        place_quadrotor(plant, context, flown.start)
    # Only where nothing but the vehicles moves (`settles` without them).
    quiet = until_settled and settles(replace(scenario, other_vehicles=[]))
    if stop_at_contact or quiet:
        simulator.set_monitor(
            one_integrator_monitor(fleet_diagram, quiet, stop_at_contact)
        )
    wall_time, cpu_time, status = advance_timed(simulator, scenario.duration)
    integrator = simulator.get_integrator()
    log = fleet_diagram.logger.FindLog(context)
    times = log.sample_times().copy()
    count = fleet_diagram.chain.readings  # the sensor's
    data = log.data().T.reshape(len(times), len(fleet_diagram.flown), row_size(count))
    slices = row_slices(count)
    flights = [
        Flight(
            scenario=flown,
            method=fleet_diagram.method,
            sensor="sphere",
            collision_radius=fleet_diagram.vehicle.collision_radius,
            times=times,
            log={name: data[:, k, s] for name, s in slices.items()},
            wall_time=wall_time,
            cpu_time=cpu_time,
            integrator_steps=integrator.get_num_steps_taken(),
            derivative_evaluations=integrator.get_num_derivative_evaluations(),
        )
        for k, flown in enumerate(fleet_diagram.flown)
    ]
    if ended_trapped(status):  # mfi's escape rule: whose memory ended it
        chain = fleet_diagram.chain
        trapped = chain.trapped(chain.GetMyContextFromRoot(context))
        for flight, each in zip(flights, trapped, strict=True):
            flight.trapped = each
    return fleet_flight(flights)
