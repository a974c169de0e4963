"""The Monte Carlo benchmark: every method flown on N random fields per
density (`generator`), on Dask distributed, with confidence intervals.

Flow: the client generates the fields (seeded, cheap), then `run_tasks`
flies one reference task per field (`field_reference`, the shortest path of
`reference_path`) and one flight task per field and method (`fly_field`).
Each task carries its scenario as self-contained YAML text (convex
obstacles by their vertices: no worker reads a file of the client's) plus
the method's name or MODULE:NAME and the reference numbers, and builds its
own diagram in its worker, since Drake systems do not pickle; a user's
field is imported there by name (`dask_client` ships the client's own
module file to the workers of a remote cluster, `run_tasks` checks that it
imports on every worker before any flight). As each flight finishes, the
client appends its record to DIR/results.jsonl (one complete line, flushed
and fsynced) and, if the flight failed, writes its scenario as a one-file
replayable YAML under DIR/failures/. A rerun with the same arguments reads
the file and skips every (variant, sensor, density, seed, index, method)
already there. A flight whose worker dies is flown again on another (the
Dask scheduler reschedules it) and recorded once, when it finishes.

A flight of a static scene with the sphere sensor and no faults ends once
its vehicle has settled at the goal (`monitors.settles`,
`settled_monitor`): the rest would be a hover, and its metrics differ from
the whole duration's by the integrator's accuracy (sim_time and steps are
those flown).

Outcomes: success (reached and no collision), collision (clearance < 0 at
any logged step, reached or not), timeout (neither: stuck or too slow within
the scenario's duration), error (the simulation raised; message recorded).
Path ratio = flown path length / reference path length, over successful
flights only. Rates carry 95 % Wilson intervals; the median path ratio a
95 % distribution-free interval from order statistics.

With `moving` > 0 a share of each field's obstacles circles at
`obstacle_speed` (`generator.set_in_motion`); the records are keyed by a
variant naming both, and each counts its moving obstacles.

The task payload is the scenario itself, so a sweep can fly modified
scenarios: `run_sweep(..., modify=f, variant="name")` applies f to every
generated field on the client (e.g. switching on a `faults` block) and
keys the records by `variant` too.
"""

import dataclasses
import functools
import hashlib
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from mfi_drake.config.dynamic import moves
from mfi_drake.config.scenario import DepthCamera, Scenario, SphereSensor
from mfi_drake.config.scenario_yaml import scenario_from_yaml, scenario_to_yaml
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.files import write_json, write_text
from mfi_drake.flight.fleet import check_one_integrator
from mfi_drake.flight.methods import DEFAULT_METHODS, resolve_method
from mfi_drake.flight.result import outcome
from mfi_drake.flight.simulation import simulate
from mfi_drake.studies.cluster import Progress, Task, run_tasks
from mfi_drake.studies.records import (
    FlightKey,
    append_record,
    read_results,
    record_key,
)
from mfi_drake.studies.stats import group_stats, summary_table
from mfi_drake.world import generator
from mfi_drake.world.reference_path import Clearance, reference_path
from mfi_drake.world.validation import validate_scenario

SENSORS = {"sphere": SphereSensor, "depth": DepthCamera}


@dataclass
class SweepConfig:
    n: int = 30  # fields per density
    seed: int = 0
    methods: list[str] = field(default_factory=lambda: list(DEFAULT_METHODS))
    densities: list[float] = field(
        default_factory=lambda: [generator.DEFAULT_DENSITY]
    )  # obstacles per m³ (generator.Workspace)
    sensor: str = "sphere"  # a key of SENSORS
    out: str = "out/sweep"
    variant: str = ""  # names the `modify` applied to every field ("" = none)
    moving: float = 0.0  # share of each field's obstacles that move
    obstacle_speed: float = 0.0  # m/s, of those that move
    # m: add an obstacle whose surface is this far from the goal (None: none)
    goal_clearance: float | None = None

    def flight_keys(self) -> list[FlightKey]:
        return [
            FlightKey(self.variant, self.sensor, density, self.seed, index, method)
            for density in self.densities
            for index in range(self.n)
            for method in self.methods
        ]


# --- the tasks (run in the workers) -------------------------------------------
@functools.lru_cache(maxsize=4)
def task_scenario(scenario_yaml: str) -> Scenario:
    """The task's scenario, parsed once per worker: a field's reference and
    its flights mostly run on one worker (Dask places a task with its
    inputs), and parsing costs a few per cent of a flight. Read only."""
    return scenario_from_yaml(scenario_yaml)


def field_reference(scenario_yaml: str) -> dict:
    """The field's reference numbers: the shortest path's length, the straight
    start–goal length and the fraction of that line inside grown obstacles."""
    scenario = task_scenario(scenario_yaml)
    start, goal = np.asarray(scenario.start), np.asarray(scenario.goal)
    radius = VEHICLES[scenario.vehicle].collision_radius
    try:
        length = reference_path(scenario).length
    except ValueError:  # no path in the grid
        length = None
    return {
        "reference_length": length,
        "straight_length": float(np.linalg.norm(goal - start)),
        "blocked_fraction": Clearance(scenario, radius).blocked_fraction(
            start, goal, 0.02
        ),
    }


# How a sweep (and `tune`) flies a field: ended once its outcome is known,
# settled at the goal or in contact (`simulator.fly`).
SWEEP_ENDS = {"until_settled": True, "stop_at_contact": True}


def fly_field(scenario_yaml: str, method: str, reference: dict) -> dict:
    """Flies the scenario with `method` (a registry name or MODULE:NAME);
    the record's outcome and numbers."""
    scenario = task_scenario(scenario_yaml)
    # A method this worker cannot import fails the task (not recorded; the
    # sweep reports it lost), unlike a flight that fails.
    resolve_method(method)
    record = {"scenario": scenario.name, "obstacles": len(scenario.obstacles)}
    if moving := sum(moves(o.motion) for o in scenario.obstacles):
        record["moving"] = moving
    record.update(reference)
    try:
        m = simulate(scenario, method, **SWEEP_ENDS).metrics
    except Exception as e:  # a failed flight is a result, not a crash of the sweep
        message = " ".join(str(e).split())[:300]
        return record | {"outcome": "error", "error": f"{type(e).__name__}: {message}"}
    ratio = None
    if reference["reference_length"]:
        ratio = m["path_length"] / reference["reference_length"]
    keep = ["reached", "collided", "path_length", "convergence_time"]
    keep += ["min_clearance", "final_error", "sim_time", "wall_time", "steps"]
    result = {"outcome": outcome(m), "path_ratio": ratio}
    return record | result | {k: m[k] for k in keep}


def summarize(config: SweepConfig, records: list[dict]) -> dict:
    """summary.json: per method, all densities pooled and by density."""
    wanted = set(config.flight_keys())
    records = [r for r in records if record_key(r) in wanted]
    methods = {}
    for method in config.methods:
        mine = [r for r in records if r["method"] == method]
        by_density = {
            f"{d:g}": group_stats([r for r in mine if r["density"] == d])
            for d in config.densities
        }
        methods[method] = group_stats(mine) | {"by_density": by_density}
    return {
        "config": dataclasses.asdict(config),
        "workspace": dataclasses.asdict(generator.DEFAULT_WORKSPACE),
        "duration": generator.DEFAULT_DURATION,
        "flights": len(records),
        "methods": methods,
    }


@dataclass
class SweepRun:
    summary: dict
    ran: int  # flights flown now
    skipped: int  # flights found done in results.jsonl
    lost: list[str]  # flights the cluster could not run (rerun to retry)


def _failure_path(config: SweepConfig, key: FlightKey, scenario: Scenario) -> str:
    """failures/[variant_][sensor_]method_field.yaml (the default sphere sensor
    and no variant leave their part out). A variant too long for a file
    name, or holding a path separator (a long --set), is named by a hash
    of its text; the file's header names it whole."""
    variant = key.variant
    if len(variant) > 64 or os.sep in variant or "/" in variant:
        variant = "variant-" + hashlib.sha1(variant.encode()).hexdigest()[:8]
    parts = [variant, "" if key.sensor == "sphere" else key.sensor, key.method]
    name = "_".join([p for p in parts if p] + [scenario.name])
    return os.path.join(config.out, "failures", f"{name}.yaml")


def make_field(config: SweepConfig, density: float, index: int) -> Scenario:
    scenario = generator.random_field(
        config.seed, index, density, sensor=SENSORS[config.sensor]()
    )
    if config.goal_clearance is not None:
        scenario = generator.near_goal(
            scenario, config.seed, index, config.goal_clearance
        )
    if config.moving > 0.0:
        scenario = generator.set_in_motion(
            scenario, config.seed, index, config.moving, config.obstacle_speed
        )
    return scenario


class Tasks(NamedTuple):
    """What a sweep flies and how it sums up: `make_field(config, density,
    index)`, the task `reference(yaml)` and its record keys, the task
    `fly(yaml, method, reference)`, `summarize(config, records)` and
    `table(summary)`. A sweep of several vehicles has its own
    (`studies.fleet_sweep`)."""

    make_field: Callable
    reference: Callable
    reference_keys: tuple[str, ...]
    fly: Callable
    summarize: Callable
    table: Callable


SINGLE = Tasks(
    make_field,
    field_reference,
    ("reference_length", "straight_length", "blocked_fraction"),
    fly_field,
    summarize,
    summary_table,
)


def run_sweep(
    config: SweepConfig,
    client,
    modify: Callable[[Scenario], Scenario] | None = None,
    progress_stream=sys.stderr,
    tasks: Tasks = SINGLE,
) -> SweepRun:
    """Flies every flight of `config` not yet in DIR/results.jsonl on the
    Dask `client`, then writes DIR/summary.json and DIR/table.md (the
    command draws DIR/sweep.png from the summary). Raises ScenarioError if
    the first field cannot be flown (e.g. a sensor the diagram does not
    support). `tasks`: what each field is and how it is flown (`SINGLE`:
    one vehicle a field)."""
    os.makedirs(config.out, exist_ok=True)
    results_path = os.path.join(config.out, "results.jsonl")
    records = read_results(results_path)
    done = {record_key(r) for r in records}
    todo = [k for k in config.flight_keys() if k not in done]
    skipped = len(config.flight_keys()) - len(todo)
    known = {
        record_key(r).field: {k: r[k] for k in tasks.reference_keys} for r in records
    }
    fields: dict[tuple, Scenario] = {}
    texts: dict[tuple, str] = {}  # each field's YAML, written once
    submitted = []
    for key in todo:
        field_key = key.field
        if field_key not in fields:
            scenario = field_to_fly(config, tasks, modify, key.density, key.index)
            if not fields:
                validate_scenario(scenario, scenario.name)
                check_one_integrator(scenario, config.methods)
            fields[field_key] = scenario
            texts[field_key] = scenario_to_yaml(scenario)
            if field_key not in known:
                known[field_key] = Task(
                    f"reference-{scenario.name}-{key.sensor}-{key.variant}",
                    tasks.reference,
                    (texts[field_key],),
                )
        scenario = fields[field_key]
        task = Task(
            f"flight-{key.method}-{scenario.name}-{key.sensor}-{key.variant}",
            tasks.fly,
            (texts[field_key], key.method, known[field_key]),
        )
        submitted.append((key, task))
    progress = Progress(len(submitted), progress_stream)
    with open(results_path, "a") as f:

        def on_result(key: FlightKey, result: dict) -> None:
            record = key._asdict() | result
            append_record(f, record)
            records.append(record)
            if record["outcome"] != "success":
                path = _failure_path(config, key, fields[key.field])
                generator.write_scenario(
                    fields[key.field],
                    path,
                    header=(
                        f"# {record['outcome']} of {key.method} in the sweep "
                        f"(seed {key.seed}, field {key.index}, density "
                        f"{key.density:g}, {key.sensor} sensor"
                        f"{', variant ' + key.variant if key.variant else ''}).\n"
                        f"# Replay: mfi-drake run {os.path.basename(path)} "
                        f"--method {key.method}\n"
                    ),
                )
            progress.step(f"({record['outcome']}: {key.method} {record['scenario']})")

        lost = run_tasks(client, submitted, on_result, config.methods, progress)
    summary = tasks.summarize(config, records)
    write_json(os.path.join(config.out, "summary.json"), summary)
    write_text(os.path.join(config.out, "table.md"), tasks.table(summary) + "\n")
    return SweepRun(
        summary=summary, ran=len(todo) - len(lost), skipped=skipped, lost=lost
    )


def field_to_fly(
    config: SweepConfig,
    tasks: Tasks,
    modify: Callable[[Scenario], Scenario] | None,
    density: float,
    index: int,
) -> Scenario:
    """Field `index` at `density` as the sweep flies it: made by `tasks`,
    then `modify` layered on it (self-contained again: its overrides may
    name mesh files)."""
    scenario = tasks.make_field(config, density, index)
    if modify is None:
        return scenario
    return generator.self_contained(modify(scenario))
