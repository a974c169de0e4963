"""Flying a scenario: `simulate` builds what the scenario needs and flies
it, one vehicle (`simulator.fly`), a fleet by exchange
(`fleet_exchange.fly_fleet`) or a fleet, or a lone vehicle on the compiled
engine, on one integrator (`one_integrator.fly_one_integrator`), and
returns the `Flight` with its metrics (`result`)."""

import dataclasses
import logging
from collections.abc import Callable

from mfi_drake.config.scenario import Scenario
from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.fleet import flies_compiled, user_fallback
from mfi_drake.flight.fleet_exchange import fly_fleet
from mfi_drake.flight.methods import Method
from mfi_drake.flight.one_integrator import fly_one_integrator
from mfi_drake.flight.result import Flight
from mfi_drake.flight.simulator import fly

_log = logging.getLogger("mfi_drake")


def simulate(
    scenario: Scenario,
    method: "str | Callable | Method" = "mfi",
    until_settled: bool = False,
    stop_at_contact: bool = False,
    processes: int = 1,
) -> Flight:
    """Builds the diagram of `scenario`, flies it for scenario.duration with the
    scenario's SimulatorConfig and returns the logged flight and its metrics.

    `method`: "mfi", "apf", "gf" (`methods.METHODS`), a user's navigation
    field as "MODULE:NAME" or as the function itself (see `methods`).
    `until_settled`, `stop_at_contact`: see `fly`. With `other_vehicles`,
    every vehicle is flown (`fly_fleet`), over `processes` processes; with
    `fleet_integration: one`, or alone with `engine: compiled`, on one
    integrator in this process, the chain compiled (`fly_one_integrator`).
    The metrics name the engine that flew ("engine": "systems" or
    "compiled"): a user's field that numba cannot compile flies on
    `systems`, and one line on the "mfi_drake" logger says why."""
    why = user_fallback(scenario, method)
    if why is not None:
        _log.warning("mfi-drake: %s: engine: systems (%s)", scenario.name, why)
        scenario = dataclasses.replace(scenario, engine="systems")
    if flies_compiled(scenario):
        flight = fly_one_integrator(scenario, method, until_settled, stop_at_contact)
        flight.metrics["engine"] = "compiled"
    elif scenario.other_vehicles:
        flight = fly_fleet(scenario, method, until_settled, stop_at_contact, processes)
    else:
        flight = fly(build_diagram(scenario, method), until_settled, stop_at_contact)
    flight.metrics.setdefault("engine", "systems")
    return flight
