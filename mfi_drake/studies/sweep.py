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

import contextlib
import dataclasses
import functools
import hashlib
import json
import logging
import math
import os
import sys
import time
import zlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import NamedTuple

import numpy as np

from mfi_drake.config.dynamic import moves
from mfi_drake.config.faults import Faults
from mfi_drake.config.scenario import (
    DepthCamera,
    Scenario,
    SphereSensor,
    layer,
    scenario_from_yaml,
    scenario_to_yaml,
)
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.files import write_json, write_text
from mfi_drake.flight.fleet import check_one_integrator
from mfi_drake.flight.methods import METHODS, MethodError, import_field, resolve_method
from mfi_drake.flight.result import OUTCOMES as FLIGHT_OUTCOMES
from mfi_drake.flight.result import outcome
from mfi_drake.flight.simulation import simulate
from mfi_drake.world import generator
from mfi_drake.world.reference_path import Clearance, reference_path
from mfi_drake.world.validation import validate_scenario

Z_95 = 1.959964  # two-sided 95 % normal quantile
SENSORS = {"sphere": SphereSensor, "depth": DepthCamera}


class FlightKey(NamedTuple):
    """What identifies a flight in results.jsonl."""

    variant: str
    sensor: str
    density: float
    seed: int
    index: int
    method: str

    @property
    def field(self) -> tuple:
        """The field's part of the key (all but the method)."""
        return self[:5]


KEY_FIELDS = FlightKey._fields
OUTCOMES = (*FLIGHT_OUTCOMES, "error")  # error: the simulation raised


@dataclass
class SweepConfig:
    n: int = 30  # fields per density
    seed: int = 0
    methods: list[str] = field(default_factory=lambda: list(METHODS))
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


# --- results file ---------------------------------------------------------------
def record_key(record: dict) -> FlightKey:
    return FlightKey(*(record[k] for k in KEY_FIELDS))


def read_results(path: str) -> list[dict]:
    """The complete records in `path`; a trailing partial line (a kill in the
    middle of a write) is cut off the file."""
    if not os.path.exists(path):
        return []
    with open(path, "rb") as f:
        data = f.read()
    end = data.rfind(b"\n") + 1
    if end < len(data):
        os.truncate(path, end)
    return [json.loads(line) for line in data[:end].splitlines() if line.strip()]


def append_record(f, record: dict) -> None:
    """One complete line, on disk before this returns."""
    f.write(json.dumps(record, allow_nan=False) + "\n")
    f.flush()
    os.fsync(f.fileno())


# --- statistics -----------------------------------------------------------------
def wilson_interval(k: int, n: int, z: float = Z_95) -> list[float] | None:
    """Wilson score interval of a binomial proportion k/n."""
    if n == 0:
        return None
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    # min/max: at k = 0 or n rounding may put the end a hair inside p.
    return [max(0.0, min(p, centre - half)), min(1.0, max(p, centre + half))]


def median_interval(values, z: float = Z_95) -> list[float] | None:
    """Distribution-free ~95 % interval of the median: the order statistics of
    ranks n/2 ∓ z√n/2 (normal approximation of the binomial ranks)."""
    x = np.sort(np.asarray(values, float))
    n = len(x)
    if n == 0:
        return None
    lo = max(1, math.floor(n / 2 - z * math.sqrt(n) / 2))
    hi = min(n, math.ceil(1 + n / 2 + z * math.sqrt(n) / 2))
    return [float(x[lo - 1]), float(x[hi - 1])]


def _median(values) -> float | None:
    return float(np.median(values)) if len(values) else None


def group_stats(records: list[dict]) -> dict:
    """Rates with intervals and the path-ratio and convergence statistics."""
    n = len(records)
    out: dict = {"n": n}
    for kind in OUTCOMES:
        k = sum(r["outcome"] == kind for r in records)
        out[f"{kind}_rate"] = k / n if n else None
        out[f"{kind}_rate_ci95"] = wilson_interval(k, n)
    ok = [r for r in records if r["outcome"] == "success"]
    ratios = [r["path_ratio"] for r in ok if r["path_ratio"] is not None]
    out["median_path_ratio"] = _median(ratios)
    out["median_path_ratio_ci95"] = median_interval(ratios)
    out["p90_path_ratio"] = float(np.percentile(ratios, 90)) if ratios else None
    out["median_convergence_time"] = _median([r["convergence_time"] for r in ok])
    # Fields whose straight start–goal line is clear of the grown obstacles:
    # there the shortest path is the line, so any detour is the method's.
    clear = [
        r["path_ratio"]
        for r in ok
        if r["path_ratio"] is not None and r["blocked_fraction"] == 0.0
    ]
    out["clear_line_flights"] = len(clear)
    out["median_path_ratio_clear_line"] = _median(clear)
    refs = [
        r["reference_length"] / r["straight_length"]
        for r in records
        if r["reference_length"]
    ]
    out["median_reference_detour"] = _median(refs)
    blocked = [r["blocked_fraction"] for r in records]
    out["line_blocked_fields"] = float(np.mean(np.array(blocked) > 0)) if n else None
    out["mean_blocked_fraction"] = float(np.mean(blocked)) if n else None
    return out


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


def rate_cell(stats: dict, outcome: str) -> str:
    """ "rate [low, high]" of an outcome (95 % Wilson interval), "–" if none."""
    rate, ci = stats[f"{outcome}_rate"], stats[f"{outcome}_rate_ci95"]
    if rate is None:
        return "–"
    return f"{rate:.2f} [{ci[0]:.2f}, {ci[1]:.2f}]"


def _num(value, digits: int = 2) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


def summary_table(summary: dict) -> str:
    """A Markdown table: one row per method and density."""
    lines = [
        "| method | density [1/m³] | flights | success [95% CI] | collision [95% CI] "
        "| timeout [95% CI] | median path ratio [95% CI] | p90 path ratio "
        "| median path ratio, clear line (fields) | median convergence time [s] |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for method, pooled in summary["methods"].items():
        for density, s in pooled["by_density"].items():
            ci = s["median_path_ratio_ci95"]
            median = _num(s["median_path_ratio"], 3)
            if ci:
                median += f" [{ci[0]:.3f}, {ci[1]:.3f}]"
            errors = (
                f" ({s['error_rate'] * s['n']:.0f} errors)" if s["error_rate"] else ""
            )
            lines.append(
                f"| {method} | {density} | {s['n']}{errors} "
                f"| {rate_cell(s, 'success')} | {rate_cell(s, 'collision')} "
                f"| {rate_cell(s, 'timeout')} | {median} "
                f"| {_num(s['p90_path_ratio'], 3)} "
                f"| {_num(s.get('median_path_ratio_clear_line'), 3)} "
                f"({s.get('clear_line_flights', 0)}) "
                f"| {_num(s['median_convergence_time'], 1)} |"
            )
    return "\n".join(lines)


# --- the run ----------------------------------------------------------------------
class Progress:
    """A text progress bar on stderr (a line per 10 % when not a terminal)."""

    def __init__(self, total: int, stream=sys.stderr):
        self.total, self.done, self.stream = total, 0, stream
        self.start = time.monotonic()
        self._tty = stream.isatty()
        self._shown = -1

    def step(self, note: str = "") -> None:
        self.done += 1
        tenth = 10 * self.done // max(self.total, 1)
        if not self._tty and tenth == self._shown and self.done < self.total:
            return
        self._shown = tenth
        elapsed = time.monotonic() - self.start
        eta = elapsed / self.done * (self.total - self.done)
        filled = 30 * self.done // max(self.total, 1)
        line = (
            f"[{'#' * filled}{'.' * (30 - filled)}] {self.done}/{self.total} flights, "
            f"{elapsed:.0f} s, ~{eta:.0f} s left {note}"
        )
        end = "\r" if self._tty and self.done < self.total else "\n"
        self.stream.write(("\r" if self._tty else "") + line + end)
        self.stream.flush()


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


class ClusterError(RuntimeError):
    """The cluster cannot fly the tasks (unreachable or refused, no workers,
    a user's field that a worker cannot import); one line for the user."""


def require_dask() -> None:
    """Raises ClusterError, before anything is flown, where Dask distributed
    (the `sweep` extra) is not installed."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise ClusterError(
            "sweep and tune need Dask distributed: pip install 'mfi_drake[sweep]'"
        ) from None


WORKER_WAIT = 60.0  # s a run waits for a worker, at its start or when all left


def _one_line(e: BaseException) -> str:
    return f"{type(e).__name__}: {' '.join(str(e).split())}"[:300]


@contextlib.contextmanager
def dask_client(
    workers: int, scheduler: str | None, methods: Sequence[str] = ()
) -> Iterator:
    """A Dask client of the cluster at `scheduler` (tcp:// or tls://, the
    latter with the certificates of Dask's own configuration:
    distributed.comm.tls.*, in a config file or DASK_DISTRIBUTED__COMM__TLS__*
    variables), the client's own modules of `methods` shipped to its workers
    (`ship_modules`); else of a LocalCluster of `workers` single-threaded
    worker processes. Closed on exit. Raises ClusterError if the scheduler
    cannot be reached or refuses the client.

    The local workers are forked from a fork server that has imported this
    module (Drake, the simulation, the reference path) once: a spawned
    worker starts a fresh interpreter and imports all of it, seconds per
    worker on a shared machine, where a fork takes milliseconds. The fork
    server is single-threaded, so forking it is safe, unlike forking this
    process."""
    import dask
    from distributed import Client, LocalCluster
    from distributed.utils import get_mp_context

    if scheduler:
        try:
            client = Client(scheduler, timeout=10)
        except (OSError, TypeError, ValueError) as e:
            why = f"({_one_line(e)})"
            if isinstance(e, TypeError) and scheduler.startswith("tls://"):
                why = (  # Dask's words: "TLS expects a `ssl_context` argument"
                    "without a certificate: set Dask's distributed.comm.tls.ca-file, "
                    ".client.cert and .client.key (or DASK_DISTRIBUTED__COMM__TLS__*)"
                )
            raise ClusterError(
                f"--scheduler = {scheduler!r}: cannot connect {why}"
            ) from None
        with client:
            ship_modules(client, methods)
            yield client
        return
    with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}):
        get_mp_context().set_forkserver_preload(["distributed", __name__])
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # a free port: no clash with other clusters
            silence_logs=logging.ERROR,
        )
    with cluster, Client(cluster) as client:
        yield client


def _user_modules(methods: Sequence[str]) -> Iterator[str]:
    """The top-level modules of the MODULE:NAME methods."""
    for method in methods:
        if method not in METHODS:
            yield method.partition(":")[0].partition(".")[0]


def ship_modules(client, methods: Sequence[str]) -> None:
    """Ships the client's own module of each MODULE:NAME method to every
    worker of the cluster (a Dask worker plugin, so to those joining later
    too): a .py file, or its top-level package as a zip, written into the
    worker's directory and put on its import path. An installed module
    (under site-packages) and this package are not shipped: the workers
    have their own. Importing is left to the tasks, and to `run_tasks`'
    check, which names a worker where it fails."""
    import importlib
    import shutil
    import tempfile

    from distributed import WorkerPlugin

    class ShipModule(WorkerPlugin):
        def __init__(self, filename: str, data: bytes):
            self.filename, self.data = filename, data

        def setup(self, worker) -> None:
            path = os.path.join(worker.local_directory, self.filename)
            with open(path, "wb") as f:
                f.write(self.data)
            entry = path if path.endswith(".zip") else worker.local_directory
            if entry not in sys.path:
                sys.path.insert(0, entry)
            importlib.invalidate_caches()

    for name in dict.fromkeys(_user_modules(methods)):
        path = getattr(importlib.import_module(name), "__file__", None) or ""
        parts = set(os.path.normpath(path).split(os.sep))
        if (
            not path
            or name == "mfi_drake"
            or parts & {"site-packages", "dist-packages"}
        ):
            continue
        with tempfile.TemporaryDirectory() as tmp:
            if os.path.basename(path) == "__init__.py":
                package = os.path.dirname(path)
                path = shutil.make_archive(
                    os.path.join(tmp, name), "zip", os.path.dirname(package), name
                )
            with open(path, "rb") as f:
                plugin = ShipModule(os.path.basename(path), f.read())
        client.register_plugin(plugin, name=f"mfi-drake-ship-{name}")


def _import_problem(methods: Sequence[str]) -> str | None:
    """Run on a worker: the first MODULE:NAME that does not import there."""
    for method in methods:
        try:
            import_field(method)
        except MethodError as e:
            return str(e)
    return None


def _wait_for_workers(client, why: str) -> None:
    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT)
    except TimeoutError:
        raise ClusterError(
            f"the Dask cluster has no workers: {why} within {WORKER_WAIT:g} s"
        ) from None


@dataclass(frozen=True)
class Task:
    """A function to run on the cluster: `args` may hold other Tasks, each
    replaced by its result (run once per key)."""

    key: str  # Dask's key: names the task, the same on a rerun
    function: Callable
    args: tuple


def run_tasks(
    client,
    tasks: Sequence[tuple[object, Task]],
    on_result: Callable[[object, dict], None],
    methods: Sequence[str] = (),
    progress: Progress | None = None,
) -> list[str]:
    """Runs every (tag, task) on the cluster and calls on_result(tag, result)
    once for each as it finishes; returns a line for each task the cluster
    lost (its worker died `distributed.scheduler.allowed-failures` times,
    or a MODULE:NAME that its worker could not import): a rerun retries it.

    First waits up to WORKER_WAIT for a worker and checks that every
    MODULE:NAME of `methods` imports on every worker (ClusterError naming
    the module and the worker if not). A task whose worker dies is run
    again on another by the scheduler. If every worker has gone, it waits
    WORKER_WAIT for one to join, then raises ClusterError (the results
    handed to on_result stay)."""
    from distributed import as_completed

    _wait_for_workers(client, "none joined")
    if user := [m for m in methods if m not in METHODS]:
        # A worker that dies meanwhile returns its error: it flies nothing.
        checks = client.run(_import_problem, user, on_error="return")
        for worker, problem in checks.items():
            if isinstance(problem, str):
                raise ClusterError(f"--methods: {problem} on worker {worker}")
    submitted = {}

    def submit(task: Task):
        if task.key not in submitted:
            args = [submit(a) if isinstance(a, Task) else a for a in task.args]
            submitted[task.key] = client.submit(task.function, *args, key=task.key)
        return submitted[task.key]

    futures = {submit(task): tag for tag, task in tasks}
    # The scheduler keeps a dependency while a task needs it; a finished
    # task's result is let go with its future, as soon as it is handed on.
    submitted.clear()
    lost = []
    pending = as_completed(futures)
    idle = time.monotonic()
    while not pending.is_empty():
        batch = pending.next_batch(block=False)
        if not batch:
            if time.monotonic() - idle > 5.0 and not client.nthreads():
                _wait_for_workers(client, "all left, and none joined")
                idle = time.monotonic()
            time.sleep(0.1)
            continue
        idle = time.monotonic()
        for future in batch:
            tag = futures.pop(future)
            try:
                result = future.result()
            except Exception as e:  # the cluster lost it (a killed worker, ...)
                lost.append(f"{tag}: {_one_line(e)}")
                if progress is not None:
                    progress.step("(lost)")
                continue
            on_result(tag, result)
    return lost


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


def goal_variant(gap: float | None) -> str:
    """A name for a sweep variant of goals near a surface ("" for none)."""
    return "" if gap is None else f"goal_clearance={gap:g}"


def motion_variant(share: float, speed: float) -> str:
    """A name for a sweep variant of moving obstacles ("" for none)."""
    return f"moving={share:g},obstacle_speed={speed:g}" if share > 0.0 else ""


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


# --- faults flown on every field ------------------------------------------------
def fault_variant(faults: Faults) -> str:
    """A name for a sweep variant: the fields that differ from the defaults,
    as "field=value" joined by commas ("" for no faults)."""
    default = Faults()
    return ",".join(
        f"{f.name}={getattr(faults, f.name)!r}"
        for f in fields(faults)
        if getattr(faults, f.name) != getattr(default, f.name)
    )


def with_faults(scenario, faults: Faults):
    """A copy of `scenario` with `faults`, the seed offset by a CRC of the
    scenario's name so that the fields of a sweep draw independent noise."""
    seed = faults.seed + zlib.crc32(scenario.name.encode())
    return replace(scenario, faults=replace(faults, seed=seed))


def with_overrides(scenario: Scenario, overrides: list[tuple[str, str]]) -> Scenario:
    """`scenario` with each (where, YAML text) override layered on it, as
    `mfi-drake run --set/--override` layers them on a file."""
    for where, text in overrides:
        scenario = layer(scenario, text, where)
    return scenario


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


def layered(
    scenario: Scenario,
    overrides: list[tuple[str, str]] = (),
    faults: Faults | None = None,
) -> Scenario:
    """A field with a command's overrides layered on it, then its faults."""
    scenario = with_overrides(scenario, overrides)
    return scenario if faults is None else with_faults(scenario, faults)


def variant_name(
    overrides: list[tuple[str, str]] = (),
    faults: Faults | None = None,
    motion: str = "",
    goal: str = "",
) -> str:
    """The sweep variant of a motion (`motion_variant`), goals near a
    surface (`goal_variant`), overrides and faults: their names joined by
    commas, "" for none of them."""
    parts = [
        motion,
        goal,
        override_variant(overrides),
        fault_variant(faults) if faults is not None else "",
    ]
    return ",".join(part for part in parts if part)


def override_variant(overrides: list[tuple[str, str]]) -> str:
    """A name for a sweep variant of overrides: each --set text as given, each
    file as its name and a hash of its text (so a changed file is a new
    variant)."""
    parts = []
    for where, text in overrides:
        if where.startswith("--set"):
            parts.append(" ".join(text.split()))
        else:
            digest = hashlib.sha1(text.encode()).hexdigest()[:8]
            parts.append(f"{os.path.basename(where)}@{digest}")
    return ";".join(parts)
