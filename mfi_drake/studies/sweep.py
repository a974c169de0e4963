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
the scenario's duration), trapped (neither, ended by mfi's escape rule
out of options), error (the simulation raised; message recorded).
Path ratio = flown path length / reference path length, over successful
flights only. Rates carry 95 % Wilson intervals; the median path ratio a
95 % distribution-free interval from order statistics.

With `moving` > 0 a share of each field's obstacles circles at
`obstacle_speed` (`generator.set_in_motion`); the records are keyed by a
variant naming both, and each counts its moving obstacles.

With `world` other than "random" the fields are the generated non-convex
worlds (`world.nonconvex`, docs/nonconvex.md; "clutter" and "floorplan",
`world.benchmark_worlds`) instead: worlds 0..n−1 of
each class (`world_kinds`), where density has no sense (the records'
density is None, their `world` the class; a random field's record has no
`world`), summed up by class rather than density. A trapped flight (the
escape rule ran out of options: `flight.result.outcome`) is an outcome of
its own.

The task payload is the scenario itself, so a sweep can fly modified
scenarios: `run_sweep(..., modify=f, variant="name")` applies f to every
generated field on the client (e.g. switching on a `faults` block) and
keys the records by `variant` too.
"""

import dataclasses
import functools
import hashlib
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from mfi_drake.config.dynamic import moves
from mfi_drake.config.scenario import Scenario, SphereSensor
from mfi_drake.config.scenario_yaml import scenario_from_yaml, scenario_to_yaml
from mfi_drake.config.sensors import DepthCamera
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.files import write_json, write_text
from mfi_drake.flight.fleet import check_engine, on_compiled
from mfi_drake.flight.methods import DEFAULT_METHODS, resolve_method
from mfi_drake.flight.result import outcome
from mfi_drake.flight.simulation import simulate
from mfi_drake.studies.cluster import Progress, Task, run_tasks
from mfi_drake.studies.records import (
    RANDOM,
    FlightKey,
    ResultsFile,
    key_record,
    read_results,
    record_key,
)
from mfi_drake.studies.stats import group_stats, summary_table
from mfi_drake.world import benchmark_worlds, generator, nonconvex
from mfi_drake.world.reference_path import Clearance, reference_path
from mfi_drake.world.validation import validate_scenario

SENSORS = {"sphere": SphereSensor, "depth": DepthCamera}
NONCONVEX = "nonconvex"  # every class of nonconvex.KINDS
# What a sweep can fly: with the benchmarks' classes (BARN-like clutter in a
# slab, indoor floor plans: `world.benchmark_worlds`).
WORLDS = (RANDOM, *nonconvex.KINDS, NONCONVEX, *benchmark_worlds.KINDS)


def world_kinds(world: str) -> tuple[str, ...]:
    """The classes of generated worlds `world` names (a KINDS, or NONCONVEX:
    all of them)."""
    return nonconvex.KINDS if world == NONCONVEX else (world,)


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
    # One of WORLDS: RANDOM (the random fields, at `densities`) or the
    # generated worlds of `world_kinds` (n of each class; `densities` unused).
    world: str = RANDOM

    def groups(self) -> list[tuple[float | None, str]]:
        """(density, world) of each group of n fields: the densities of the
        random fields, or the classes of the generated worlds."""
        if self.world == RANDOM:
            return [(density, RANDOM) for density in self.densities]
        return [(None, kind) for kind in world_kinds(self.world)]

    def flight_keys(self) -> list[FlightKey]:
        return [
            FlightKey(self.variant, self.sensor, density, self.seed, i, method, world)
            for density, world in self.groups()
            for i in range(self.n)
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
    radius = as_vehicle(scenario.vehicle).collision_radius
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
    keep += ["engine"]  # the one that flew (`default_engine`)
    result = {"outcome": outcome(m), "path_ratio": ratio}
    return record | result | {k: m[k] for k in keep}


def summarize(config: SweepConfig, records: list[dict]) -> dict:
    """summary.json: per method, all fields pooled and by density
    ("by_density") or, for generated worlds, by class ("by_world")."""
    wanted = set(config.flight_keys())
    records = [r for r in records if record_key(r) in wanted]
    by = "by_density" if config.world == RANDOM else "by_world"
    methods = {}
    for method in config.methods:
        grouped: dict[tuple, list[dict]] = {}
        for r in records:
            key = record_key(r)
            if key.method == method:
                grouped.setdefault((key.density, key.world), []).append(r)
        mine = [r for group in grouped.values() for r in group]
        groups = {
            world if density is None else f"{density:g}": group_stats(
                grouped.get((density, world), [])
            )
            for density, world in config.groups()
        }
        methods[method] = group_stats(mine) | {by: groups}
    where = {
        "workspace": dataclasses.asdict(generator.DEFAULT_WORKSPACE),
        "duration": generator.DEFAULT_DURATION,
    }
    if config.world in benchmark_worlds.KINDS:
        where = {"duration": benchmark_worlds.DURATION}
    elif config.world != RANDOM:
        where = {"duration": nonconvex.DURATION}
    return {
        "config": dataclasses.asdict(config),
        **where,
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


def field_words(key: FlightKey) -> str:
    """ "density 0.1" or "world cup": the field's group in words."""
    if key.world == RANDOM:
        return f"density {key.density:g}"
    return f"world {key.world}"


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
    progress_stream=None,
    tasks: Tasks = SINGLE,
) -> SweepRun:
    """Flies every flight of `config` not yet in DIR/results.jsonl on the
    Dask `client`, then writes DIR/summary.json and DIR/table.md (the
    command draws DIR/sweep.png from the summary). Raises ScenarioError if
    the first field cannot be flown (e.g. a sensor the diagram does not
    support). `tasks`: what each field is and how it is flown (`SINGLE`:
    one vehicle a field)."""
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
            scenario = field_to_fly(config, tasks, modify, key)
            if not fields:
                validate_scenario(scenario, scenario.name)
                check_engine(scenario, config.methods)
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
    # DIR and results.jsonl are made at the first record: a run the cluster
    # refuses (`check_cluster`) leaves nothing behind.
    with ResultsFile(results_path) as results:

        def on_result(key: FlightKey, result: dict) -> None:
            record = key_record(key) | result
            results.append(record)
            records.append(record)
            if record["outcome"] != "success":
                path = _failure_path(config, key, fields[key.field])
                generator.write_scenario(
                    fields[key.field],
                    path,
                    header=(
                        f"# {record['outcome']} of {key.method} in the sweep "
                        f"(seed {key.seed}, field {key.index}, {field_words(key)}"
                        f", {key.sensor} sensor"
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
    key: FlightKey,
) -> Scenario:
    """The field of `key` as the sweep flies it: a random field made by
    `tasks` (at key.density) or the generated world of key.world, then
    `modify` layered on it (self-contained again: its overrides may name
    mesh files)."""
    if key.world == RANDOM:
        scenario = tasks.make_field(config, key.density, key.index)
    elif key.world in benchmark_worlds.KINDS:
        sensor = SENSORS[config.sensor]()
        scenario = benchmark_worlds.benchmark_world(
            key.world, config.seed, key.index, sensor=sensor
        )
    else:
        sensor = SENSORS[config.sensor]()
        scenario = nonconvex.nonconvex_world(
            key.world, config.seed, key.index, sensor=sensor
        )
    if modify is None:
        return scenario
    return generator.self_contained(modify(scenario))


def _compiled_under(
    scenario: Scenario, modify: Callable[[Scenario], Scenario] | None
) -> Scenario:
    compiled = dataclasses.replace(scenario, engine="compiled")
    return compiled if modify is None else modify(compiled)


def default_engine(
    config: SweepConfig,
    tasks: Tasks,
    modify: Callable[[Scenario], Scenario] | None,
) -> Callable[[Scenario], Scenario] | None:
    """`modify` with `engine: compiled` layered under it, where every method
    of `config` flies the first field so layered on the compiled engine
    (`flight.fleet.unsupported`: not cameras, maps, a user's field numba
    cannot compile, a fleet's faults); else `modify`. A layer of
    `modify` that names an engine wins: `engine: systems` undoes the default, and
    `engine: compiled` flies (or is refused by `check_engine`) as asked.
    `sweep`'s default. The engines fly the same flights (benchmarks/
    engines.py), so the variant and the records' keys do not name it."""
    under = functools.partial(_compiled_under, modify=modify)
    first = field_to_fly(config, tasks, under, config.flight_keys()[0])
    if first.engine != "compiled" or not on_compiled(first, config.methods):
        return modify
    return under
