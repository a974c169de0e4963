"""The Monte Carlo of several vehicles: `mfi-drake sweep --vehicles N`.

Each field is a sweep field (`sweep.make_field`: the random obstacles at
the density) flown by N vehicles between random start and goal pairs
(`world.fleets.random_pairs`: half of them each way, so that they meet
head-on among the obstacles), every method on the same fields, on Dask
like the sweep (`sweep.run_sweep` with `FLEET`). Each vehicle's reference
is the shortest path of its own start and goal among the obstacles.

A field's flight is the fleet's (`fleet_exchange.fly_fleet`): it ends at the
first contact (with an obstacle or another vehicle) or once every vehicle
rests at its goal. Its record: the fleet's outcome (success: every vehicle
reached its goal, no contact), `vehicles_succeeded`, the vehicle–obstacle
collisions (`obstacle_collisions`, vehicles whose clearance went below
zero) and the vehicle–vehicle contact (`vehicle_contact`, least separation
≤ 0) counted apart, `deadlocks` (vehicles still short of their goals when
the clock stopped, in a field that ended without contact),
`min_separation` and each vehicle's `path_ratios` (flown / reference, for
the vehicles that succeeded).
"""

import dataclasses
from dataclasses import dataclass, replace

import numpy as np

from mfi_drake.config.scenario import Scenario
from mfi_drake.flight.diagram import vehicle_scenarios
from mfi_drake.flight.result import outcome
from mfi_drake.flight.simulation import simulate
from mfi_drake.studies.records import OUTCOMES, record_key
from mfi_drake.studies.stats import median_interval, rate_cell, wilson_interval
from mfi_drake.studies.sweep import (
    SWEEP_ENDS,
    SweepConfig,
    Tasks,
    make_field,
    task_scenario,
)
from mfi_drake.world.fleets import random_pairs
from mfi_drake.world.reference_path import reference_path


@dataclass
class FleetSweepConfig(SweepConfig):
    vehicles: int = 4  # vehicles per field


def fleet_variant(vehicles: int, variant: str = "") -> str:
    """The records' variant: the fleet's size, then any other variant."""
    return ",".join(part for part in (f"vehicles={vehicles}", variant) if part)


def make_fleet_field(config: FleetSweepConfig, density: float, index: int) -> Scenario:
    field = make_field(config, density, index)
    field = replace(field, name=f"{field.name}_v{config.vehicles}")
    return random_pairs(field, config.vehicles, config.seed, index)


def fleet_reference(scenario_yaml: str) -> dict:
    """Each vehicle's shortest path among the obstacles (None: no path)."""
    lengths = []
    for flown in vehicle_scenarios(task_scenario(scenario_yaml)):
        try:
            lengths.append(reference_path(replace(flown, other_vehicles=[])).length)
        except ValueError:  # no path in the grid
            lengths.append(None)
    return {"reference_lengths": lengths}


def fly_fleet_field(scenario_yaml: str, method: str, reference: dict) -> dict:
    """Flies the field's fleet with `method`; the record (module docstring)."""
    scenario = task_scenario(scenario_yaml)
    record = {"scenario": scenario.name, "obstacles": len(scenario.obstacles)}
    record |= {"vehicles": 1 + len(scenario.other_vehicles)} | reference
    try:
        m = simulate(scenario, method, **SWEEP_ENDS).metrics
    except Exception as e:  # a failed flight is a result, not a crash of the sweep
        message = " ".join(str(e).split())[:300]
        return record | {"outcome": "error", "error": f"{type(e).__name__}: {message}"}
    vehicles, result = m["vehicles"], outcome(m)
    ratios = [
        v["path_length"] / length if v["success"] and length else None
        for v, length in zip(vehicles, reference["reference_lengths"], strict=True)
    ]
    contact = result == "collision"
    return record | {
        "outcome": result,
        "vehicles_succeeded": sum(v["success"] for v in vehicles),
        "obstacle_collisions": sum(v["collided"] for v in vehicles),
        "vehicle_contact": bool(m["min_separation"] <= 0.0),
        "deadlocks": 0 if contact else sum(not v["reached"] for v in vehicles),
        "min_separation": m["min_separation"],
        "path_ratios": ratios,
        "sim_time": m["sim_time"],
        "wall_time": m["wall_time"],
    }


def _rate(records: list[dict], test) -> dict:
    k, n = sum(bool(test(r)) for r in records), len(records)
    return {"k": k, "rate": k / n if n else None, "ci95": wilson_interval(k, n)}


def fleet_stats(records: list[dict]) -> dict:
    """Per method: field rates with 95 % Wilson intervals, the vehicles'
    success share, the least separations and the path ratios."""
    flown = [r for r in records if r["outcome"] != "error"]
    out: dict = {"n": len(records), "errors": len(records) - len(flown)}
    for kind in OUTCOMES:
        r = _rate(records, lambda r, kind=kind: r["outcome"] == kind)
        out[f"{kind}_rate"], out[f"{kind}_rate_ci95"] = r["rate"], r["ci95"]
    out["vehicle_contact_fields"] = _rate(flown, lambda r: r["vehicle_contact"])
    out["obstacle_collision_fields"] = _rate(flown, lambda r: r["obstacle_collisions"])
    out["deadlock_fields"] = _rate(flown, lambda r: r["deadlocks"])
    vehicles = sum(r["vehicles"] for r in flown)
    out["vehicle_success_share"] = (
        sum(r["vehicles_succeeded"] for r in flown) / vehicles if vehicles else None
    )
    separations = [r["min_separation"] for r in flown]
    out["median_min_separation"] = float(np.median(separations)) if flown else None
    out["least_min_separation"] = float(min(separations)) if flown else None
    ratios = [x for r in flown for x in r["path_ratios"] if x is not None]
    out["median_path_ratio"] = float(np.median(ratios)) if ratios else None
    out["median_path_ratio_ci95"] = median_interval(ratios)
    out["p90_path_ratio"] = float(np.percentile(ratios, 90)) if ratios else None
    return out


def fleet_summarize(config: FleetSweepConfig, records: list[dict]) -> dict:
    """summary.json: per method and density."""
    wanted = set(config.flight_keys())
    mine = [r for r in records if record_key(r) in wanted]
    return {
        "config": dataclasses.asdict(config),
        "flights": len(mine),
        "methods": {
            method: {
                f"{d:g}": fleet_stats(
                    [r for r in mine if r["method"] == method and r["density"] == d]
                )
                for d in config.densities
            }
            for method in config.methods
        },
    }


def _count(cell: dict) -> str:
    lo, hi = cell["ci95"] or (0.0, 0.0)
    return f"{cell['k']} ({cell['rate']:.2f} [{lo:.2f}, {hi:.2f}])"


def fleet_table(summary: dict) -> str:
    """A Markdown table: one row per method and density; counts of fields
    with their rates and 95 % Wilson intervals."""
    lines = [
        "| method | density [1/m³] | fields | all vehicles succeed [95% CI] "
        "| fields with vehicle–vehicle contact | fields with vehicle–obstacle "
        "collision | fields with deadlock | vehicles succeeding "
        "| least separation, median / min [m] | median path ratio [95% CI] "
        "| p90 path ratio |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for method, by_density in summary["methods"].items():
        for density, s in by_density.items():
            if not s["n"] - s["errors"]:
                continue
            ci = s["median_path_ratio_ci95"]
            median = (
                "–"
                if s["median_path_ratio"] is None
                else (
                    f"{s['median_path_ratio']:.3f}"
                    + (f" [{ci[0]:.3f}, {ci[1]:.3f}]" if ci else "")
                )
            )
            p90 = "–" if s["p90_path_ratio"] is None else f"{s['p90_path_ratio']:.3f}"
            errors = f" ({s['errors']} errors)" if s["errors"] else ""
            success = rate_cell(s, "success")
            lines.append(
                f"| {method} | {density} | {s['n']}{errors} | {success} "
                f"| {_count(s['vehicle_contact_fields'])} "
                f"| {_count(s['obstacle_collision_fields'])} "
                f"| {_count(s['deadlock_fields'])} "
                f"| {s['vehicle_success_share']:.3f} "
                f"| {s['median_min_separation']:.3f} / {s['least_min_separation']:.3f} "
                f"| {median} | {p90} |"
            )
    return "\n".join(lines)


FLEET = Tasks(
    make_fleet_field,
    fleet_reference,
    ("reference_lengths",),
    fly_fleet_field,
    fleet_summarize,
    fleet_table,
)
