"""Throughput, everything in one run: one flight against a C++-only
diagram, where a sweep flight's time goes, and sweep flights per minute.

    python benchmarks/throughput.py [--repeats 7] [--duration S] [--split 8]
        [--fields 40] [--compare 60] [--override FILE] [--seed S]
        [--scenarios 'GLOB'] [--page docs/performance.md]

Prints, all measured in this run (the machine's load average with each):

1. The planar wall flown by MFI (`flight.simulation.simulate`, the diagram
   `mfi-drake run` flies) and a reference: Drake's C++ `QuadrotorPlant`
   closed by Drake's C++ `StabilizingLQRController` set at the scenario's
   start, started there at rest, logging its state at every step, with the
   same SimulatorConfig and duration. It hovers: an LQR set at the goal,
   8 m away, commands tilts its linearisation cannot handle. Hovering is no
   idle run for the integrator: the LQR's fast attitude poles keep the
   error-controlled RK3 at short steps (~2200 in 40 s). The two are flown
   in turn, --repeats times each, and each keeps its best wall and CPU
   time; their real-time factors, steps and µs per step and per derivative
   evaluation, and the ratio MFI / reference of the real-time factors.
   Beside them the same flight on the compiled engine (`engine: compiled`,
   the chain in one compiled system), its ratio to the reference, and the
   whole command, `mfi-drake run --json` in a fresh process on each engine
   (imports, loading the compiled chain from numba's cache, the flight, the
   figure): its wall time from start to exit beside the flight's own
   real-time factor, which leaves all that out.
   The compiled flight's SceneGraph distance queries a step and their
   cost alone (`TimedQueries`), against the cost a step may have for the
   compiled engine to reach COMPILED_BAR of the C++ diagram.
   Then the floor: the MFI diagram flown with stale results
   (`StaleResults`: no arithmetic in its Python systems) costs per step
   what its structure costs, against the cost per step that a ratio of
   BAR_RATIO allows.
2. The split of a sweep flight's time (MFI on --split fresh fields at the
   default density, in this process, as a sweep's worker does it): field
   generation, the scenario's YAML both ways, the reference path (the
   field's `field_reference` task), diagram build, simulation, metrics.
3. Sweep flights per minute: the whole `mfi-drake sweep` command on
   --fields fresh fields (a seed no earlier run used) at the default
   density: MFI on a local cluster of 1 and then 2 worker processes (on
   its default engine, compiled), then every method on 2 workers on the
   systems engine (`--set 'engine: systems'`) and on its default, the same
   fields, and the ratio of their flights per minute.
4. CPU per flight of each method (mfi, mfi-paper, apf, gf) on the same
   --compare fresh fields at the default density, flown in turn in this
   process until settled, as a sweep flies them; steps and µs per step,
   and each method's CPU over GF's, every method with its shipped
   defaults; with --override (a `tune` winner file, or
   docs/results/protocol_choices.yaml: each method as the tuning protocol
   chose it), the same fields again with the file layered on.
5. Every shipped scenario (scenarios/*.yaml, or --scenarios GLOB there)
   flown as `mfi-drake run` flies it, best wall time of 2: its real-time
   factor (simulated seconds per wall second, every vehicle of it at once)
   and steps, marked where it is below REALTIME_BAR.

With --page, the printed text is also written into that page between the
lines `<!-- BEGIN throughput -->` and `<!-- END throughput -->`, with the
commit it ran at.
"""

import argparse
import dataclasses
import glob
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from pydrake.examples import StabilizingLQRController
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import LogVectorOutput

from mfi_drake.config.scenario import Scenario, ScenarioError
from mfi_drake.config.scenario_yaml import read_override, scenario_to_yaml
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.files import write_section
from mfi_drake.flight.diagram import build_diagram, make_plant
from mfi_drake.flight.methods import DEFAULT_METHODS
from mfi_drake.flight.simulation import simulate
from mfi_drake.flight.simulator import fly, run_timed, simulator_at_start
from mfi_drake.studies.sweep import (
    SWEEP_ENDS,
    field_reference,
    fly_field,
    task_scenario,
)
from mfi_drake.studies.variants import with_overrides
from mfi_drake.systems import sensors
from mfi_drake.systems.last_result import LastResult
from mfi_drake.world import generator
from mfi_drake.world.validation import load_scenario

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PLANAR_WALL = os.path.join(ROOT, "scenarios", "planar_wall.yaml")
COMPARED = ("mfi", "mfi-paper", "apf", "gf")
REALTIME_BAR = 50.0  # the issues' "no flight below 50x real time"
BAR_RATIO = 0.05  # issue 15's planar wall against the C++ diagram
COMPILED_BAR = 0.25  # issue 40's: the compiled engine against the C++ diagram


@dataclasses.dataclass
class Run:
    """A timed simulation: the best wall and CPU times over the repeats."""

    sim_time: float
    wall_time: float
    cpu_time: float
    steps: int
    derivative_evaluations: int

    @property
    def realtime_factor(self) -> float:
        return self.sim_time / self.wall_time

    @property
    def cpu_realtime_factor(self) -> float:
        return self.sim_time / self.cpu_time

    def describe(self) -> str:
        return (
            f"{self.sim_time:.1f} s simulated in {self.wall_time:.4f} s wall = "
            f"{self.realtime_factor:.1f}x real time (CPU {self.cpu_time:.4f} s = "
            f"{self.cpu_realtime_factor:.1f}x); {self.steps} steps, "
            f"{1e6 * self.cpu_time / self.steps:.1f} us CPU per step, "
            f"{self.derivative_evaluations / self.steps:.2f} derivative "
            f"evaluations per step, "
            f"{1e6 * self.cpu_time / self.derivative_evaluations:.1f} us each"
        )


def best(runs: list[Run]) -> Run:
    """The run of least wall time, with the least CPU time of them all."""
    fastest = min(runs, key=lambda run: run.wall_time)
    return dataclasses.replace(fastest, cpu_time=min(r.cpu_time for r in runs))


def mfi_run(scenario: Scenario) -> Run:
    """The scenario flown by MFI on its engine (`engine:`)."""
    flight = simulate(scenario)
    return Run(
        sim_time=flight.metrics["sim_time"],
        wall_time=flight.wall_time,
        cpu_time=flight.cpu_time,
        steps=flight.integrator_steps,
        derivative_evaluations=flight.derivative_evaluations,
    )


class PythonPassThrough(LeafSystem):
    """A Python LeafSystem that computes nothing: its output is its input
    (what any Python system in the loop costs an evaluation, at least)."""

    def __init__(self, size: int):
        super().__init__()
        port = self.DeclareVectorInputPort("u", size)
        self.DeclareVectorOutputPort(
            "y",
            size,
            lambda context, out: out.SetFromVector(port.Eval(context)),
            prerequisites_of_calc={port.ticket()},
        )


def lqr_run(scenario: Scenario, python_systems: int = 0) -> Run:
    """QuadrotorPlant + StabilizingLQRController hovering at scenario.start;
    with `python_systems` `PythonPassThrough`s in turn between the two."""
    builder = DiagramBuilder()
    plant = builder.AddSystem(make_plant(as_vehicle(scenario.vehicle)))
    controller = builder.AddSystem(
        StabilizingLQRController(plant, np.asarray(scenario.start, float))
    )
    builder.Connect(plant.get_output_port(0), controller.get_input_port())
    command = controller.get_output_port()
    for _ in range(python_systems):
        passed = builder.AddSystem(PythonPassThrough(command.size()))
        builder.Connect(command, passed.get_input_port(0))
        command = passed.get_output_port(0)
    builder.Connect(command, plant.get_input_port(0))
    LogVectorOutput(plant.get_output_port(0), builder, publish_period=0.0)
    simulator = simulator_at_start(builder.Build(), plant, scenario)
    wall_time, cpu_time = run_timed(simulator, scenario.duration)
    integrator = simulator.get_integrator()
    return Run(
        sim_time=simulator.get_context().get_time(),
        wall_time=wall_time,
        cpu_time=cpu_time,
        steps=integrator.get_num_steps_taken(),
        derivative_evaluations=integrator.get_num_derivative_evaluations(),
    )


def load() -> str:
    return f"load average {os.getloadavg()[0]:.2f}"


class StaleResults:
    """Within the block, every `LastResult` hands back the result it computed
    first (recomputing once every `refresh` calls): the navigator, selector,
    attitude PD and mixer then cost their ports' glue but not their
    arithmetic, while the sensor's SceneGraph query, the plant, the
    integrator and the logger run as usual. The vehicle no longer flies the
    scenario, but each integrator step still costs what the diagram's
    structure costs: the floor that faster arithmetic cannot go below."""

    def __init__(self, refresh: int = 50):
        self._refresh = refresh
        self._saved = None

    def __enter__(self):
        refresh = self._refresh
        self._saved = LastResult.__call__

        def stale(last, key, calc, *args):
            kept = last.__dict__.get("_stale")
            if kept is None or kept[0] >= refresh:
                kept = last.__dict__["_stale"] = [0, calc(*args)]
            kept[0] += 1
            return kept[1]

        LastResult.__call__ = stale
        return self

    def __exit__(self, *exc):
        LastResult.__call__ = self._saved


class TimedQueries:
    """Within the block, every sphere-sensor reading (`nearest_obstacles`,
    as `systems.sensors` calls it) also times SceneGraph's distance query
    it makes once more, alone, and counts it: what the card's sensor costs
    a step whatever the rest of the chain costs."""

    def __init__(self):
        self.count, self.seconds = 0, 0.0
        self._saved = None

    def __enter__(self):
        self._saved = sensors.nearest_obstacles

        def timed(query, p, threshold, *args):
            start = time.perf_counter()
            query.ComputeSignedDistanceToPoint(p, threshold)
            self.seconds += time.perf_counter() - start
            self.count += 1
            return self._saved(query, p, threshold, *args)

        sensors.nearest_obstacles = timed
        return self

    def __exit__(self, *exc):
        sensors.nearest_obstacles = self._saved


def query_floor(scenario: Scenario, lqr: "Run", repeats: int, say) -> dict:
    """The compiled flight's SceneGraph queries a step and their cost alone,
    against what a step may cost for COMPILED_BAR of the C++ diagram; and
    what one and two Python systems that compute nothing cost in the C++
    diagram (`PythonPassThrough`): the compiled engine has two a
    derivative evaluation (the card's sensor reading SceneGraph, the
    chain), which leaves what the bar allows less those and the query for
    the chain's arithmetic, its per-step event and the logger."""
    with TimedQueries() as queries:
        flight = simulate(dataclasses.replace(scenario, engine="compiled"))
    steps, evaluations = flight.integrator_steps, flight.derivative_evaluations
    per_step = queries.count / steps
    each = queries.seconds / queries.count
    allowed = lqr.cpu_time / COMPILED_BAR / steps
    say(
        f"   the compiled flight's sensor: {per_step:.2f} SceneGraph distance "
        f"queries per step ({evaluations / steps:.2f} "
        f"derivative evaluations), {1e6 * each:.1f} us each alone = "
        f"{1e6 * per_step * each:.1f} us per step; a ratio of {COMPILED_BAR:g} "
        f"allows {1e6 * allowed:.1f} us per step at its {steps} steps, query, "
        "plant, integrator, chain and logger together"
    )
    passed = {k: best([lqr_run(scenario, k) for _ in range(repeats)]) for k in (1, 2)}
    python = {
        k: (run.cpu_time - lqr.cpu_time) / run.derivative_evaluations
        for k, run in passed.items()
    }
    left = (
        allowed * steps / evaluations
        - python[2]
        - per_step * each * steps / evaluations
    )
    say(
        f"   the C++ diagram with 1 / 2 Python systems that compute nothing "
        f"(`PythonPassThrough`): {1e6 * python[1]:.1f} / {1e6 * python[2]:.1f} "
        f"us more an evaluation, ratio to C++ "
        f"{lqr.cpu_time / passed[1].cpu_time:.3f} / "
        f"{lqr.cpu_time / passed[2].cpu_time:.3f}; at the compiled flight's "
        f"evaluations a ratio of {COMPILED_BAR:g} leaves {1e6 * left:.1f} us an "
        "evaluation beside two Python systems and the query: the plant, "
        "integrator and logger, the chain's arithmetic and its events"
    )
    return {
        "queries_per_step": per_step,
        "query": each,
        "allowed": allowed,
        "python_system": python,
        "passed_through": passed,
        "left_per_evaluation": left,
    }


def against_cpp(scenario: Scenario, repeats: int, say) -> dict:
    """Part 1: the MFI flight and the C++ reference, flown in turn; then the
    same diagram with stale results (`StaleResults`): the cost of a step
    without the Python arithmetic, against the cost a step may have for the
    flight to reach BAR_RATIO of the C++ diagram's real-time factor."""
    mfi, lqr, fast = [], [], []
    on_compiled = dataclasses.replace(scenario, engine="compiled")
    mfi_run(on_compiled)  # compiled (or loaded from the cache) before timing
    say(f"1. {scenario.name}, {scenario.duration:g} s, best of {repeats} ({load()})")
    for _ in range(repeats):
        mfi.append(mfi_run(scenario))
        lqr.append(lqr_run(scenario))
        fast.append(mfi_run(on_compiled))
    mfi, lqr, fast = best(mfi), best(lqr), best(fast)
    ratio = mfi.realtime_factor / lqr.realtime_factor
    cpu_ratio = mfi.cpu_realtime_factor / lqr.cpu_realtime_factor
    compiled_ratio = fast.realtime_factor / lqr.realtime_factor
    say(f"   MFI (Python LeafSystems): {mfi.describe()}")
    say(f"   MFI (compiled engine): {fast.describe()}")
    say(f"   C++ QuadrotorPlant + LQR: {lqr.describe()}")
    say(
        f"   ratio of real-time factors MFI / C++: {ratio:.4f} wall, "
        f"{cpu_ratio:.4f} CPU; compiled / C++: {compiled_ratio:.4f} wall "
        f"({load()})"
    )
    commands = {}
    for engine in ("systems", "compiled"):
        commands[engine] = whole_command(scenario, engine)
        wall, factor = commands[engine]
        say(
            f"   the whole `mfi-drake run --json` on {engine}: {wall:.2f} s from "
            f"start to exit; the flight's realtime_factor {factor:.1f}x"
        )
    with StaleResults():
        floor = best([mfi_run(scenario) for _ in range(repeats)])
    allowed = lqr.cpu_time / BAR_RATIO / mfi.steps
    say(
        f"   the same diagram with stale results (glue, sensor query, plant, "
        f"integrator, logger; no arithmetic): {1e6 * floor.cpu_time / floor.steps:.1f}"
        f" us CPU per step ({floor.steps} steps, "
        f"{floor.derivative_evaluations / floor.steps:.2f} evaluations per step); "
        f"a ratio of {BAR_RATIO:g} allows {1e6 * allowed:.1f} us per step at the "
        f"flight's {mfi.steps} steps, {1e6 * mfi.cpu_time / mfi.steps:.1f} spent"
    )
    return {
        "mfi": mfi,
        "lqr": lqr,
        "compiled": fast,
        "compiled_floor": query_floor(scenario, lqr, repeats, say),
        "compiled_ratio": compiled_ratio,
        "commands": commands,
        "ratio": ratio,
        "cpu_ratio": cpu_ratio,
        "floor": floor,
        "allowed_per_step": allowed,
    }


def whole_command(scenario: Scenario, engine: str) -> tuple[float, float]:
    """(wall time [s] from process start to exit, the flight's own
    realtime_factor) of `mfi-drake run --json` flying `scenario` (written
    to a file) on `engine` in a fresh process."""
    with tempfile.TemporaryDirectory() as out:
        path = os.path.join(out, "scenario.yaml")
        with open(path, "w") as f:
            f.write(scenario_to_yaml(dataclasses.replace(scenario, engine=engine)))
        command = [sys.executable, "-m", "mfi_drake.app.cli", "run", path]
        start = time.perf_counter()
        done = subprocess.run(
            [*command, "--json", "--out", os.path.join(out, "run")],
            capture_output=True,
            text=True,
        )
        wall = time.perf_counter() - start
    if done.returncode not in (0, 1):  # 1: flown, not reached
        raise RuntimeError(f"{' '.join(command)}: {done.stderr.strip()}")
    metrics = json.loads(done.stdout.splitlines()[-1])
    return wall, metrics["realtime_factor"]


PIECES = ("generate", "yaml", "reference", "build", "simulate", "metrics")


def split(fields: int, seed: int, say) -> dict[str, float]:
    """Part 2: mean seconds per flight of each piece of a sweep flight."""
    totals = dict.fromkeys(PIECES, 0.0)
    steps = sim_time = 0
    for index in range(fields):
        clock = time.process_time()

        def lap(piece: str) -> None:
            nonlocal clock
            now = time.process_time()
            totals[piece] += now - clock
            clock = now

        scenario = generator.random_field(seed, index, generator.DEFAULT_DENSITY)
        lap("generate")
        text = scenario_to_yaml(scenario)  # the client's
        scenario = task_scenario(text)  # the worker's (once per field)
        lap("yaml")
        field_reference(text)
        lap("reference")
        built = build_diagram(scenario)
        lap("build")
        flight = fly(built, **SWEEP_ENDS)
        # fly() = the simulation (its own CPU time) + reading the log and
        # the metrics.
        lap("metrics")
        totals["simulate"] += flight.cpu_time
        totals["metrics"] -= flight.cpu_time
        steps += flight.integrator_steps
        sim_time += flight.metrics["sim_time"]
    whole = sum(totals.values())
    say(
        f"2. a sweep flight's CPU time, MFI on {fields} fresh fields at density "
        f"{generator.DEFAULT_DENSITY:g} (seed {seed}), flown until settled "
        f"({sim_time / fields:.1f} s simulated, {steps / fields:.0f} steps "
        f"on average; {load()}):"
    )
    for piece in PIECES:
        share = totals[piece] / whole
        mean = 1e3 * totals[piece] / fields
        say(f"   {piece:10s} {mean:7.1f} ms  {100 * share:5.1f} %")
    say(f"   {'total':10s} {1e3 * whole / fields:7.1f} ms")
    return {piece: totals[piece] / fields for piece in PIECES}


def by_method(
    fields: int, seed: int, say, layers: list[tuple[str, str]] = ()
) -> dict[str, float]:
    """Part 4: CPU per flight of each method on the same fields (in this
    process, each field's methods flown in turn, until settled), each field
    with the override `layers`."""
    cpu = dict.fromkeys(COMPARED, 0.0)
    steps = dict.fromkeys(COMPARED, 0)
    for index in range(fields):
        scenario = generator.random_field(seed, index, generator.DEFAULT_DENSITY)
        scenario = with_overrides(scenario, layers)
        for method in COMPARED:
            flight = fly(build_diagram(scenario, method), **SWEEP_ENDS)
            cpu[method] += flight.cpu_time
            steps[method] += flight.integrator_steps
    say(
        f"4. CPU per flight by method, the same {fields} fresh fields at density "
        f"{generator.DEFAULT_DENSITY:g} (seed {seed}), flown in turn until "
        f"settled ({load()}){', with ' + layers[0][0] if layers else ''}:"
    )
    for method in COMPARED:
        say(
            f"   {method:10s} {1e3 * cpu[method] / fields:7.1f} ms  "
            f"{steps[method] / fields:6.0f} steps  "
            f"{1e6 * cpu[method] / steps[method]:6.1f} us/step  "
            f"x{cpu[method] / cpu['gf']:.2f} GF's"
        )
    return {method: cpu[method] / fields for method in COMPARED}


def every_scenario(pattern: str, say) -> dict[str, float]:
    """Part 5: each shipped scenario matching `pattern`, flown as `run`
    flies it, best wall time of 2."""
    paths = sorted(glob.glob(os.path.join(ROOT, "scenarios", pattern)))
    say(
        f"5. every shipped scenario ({pattern}), best of 2, as run flies it ({load()}):"
    )
    factors = {}
    for path in paths:
        flights = [simulate(load_scenario(path)) for _ in range(2)]
        flight = min(flights, key=lambda f: f.wall_time)
        name = flight.scenario.name
        factors[name] = flight.metrics["sim_time"] / flight.wall_time
        mark = f"  below {REALTIME_BAR:g}x" if factors[name] < REALTIME_BAR else ""
        say(
            f"   {name:20s} {factors[name]:7.1f}x real time  "
            f"{flight.integrator_steps:6d} steps  {flight.sensor:6s} "
            f"{1 + len(flight.others)} vehicle(s){mark}"
        )
    return factors


def flights_per_minute(
    workers: int, fields: int, seed: int, methods: list[str], engine: str
) -> tuple[float, float]:
    """(wall time [s], flights per minute) of `mfi-drake sweep` in a fresh
    Python process: its imports, the local cluster's start-up and shutdown
    and any compile included; on its default engine (`compiled` where every
    method flies there) or, for "systems", with `--set 'engine: systems'`."""
    command = [sys.executable, "-m", "mfi_drake.app.cli", "sweep", "--n", str(fields)]
    command += ["--seed", str(seed), "--methods", ",".join(methods)]
    command += ["--workers", str(workers)]
    if engine == "systems":
        command += ["--set", "engine: systems"]
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        subprocess.run([*command, "--out", out], check=True, capture_output=True)
        wall = time.perf_counter() - start
        with open(os.path.join(out, "results.jsonl")) as f:
            records = [json.loads(line) for line in f]
    flights = fields * len(methods)
    if len(records) != flights or {r["engine"] for r in records} != {engine}:
        raise RuntimeError(f"expected {flights} flights on {engine}: {len(records)}")
    return wall, 60.0 * flights / wall


def sweeps(fields: int, seed: int, say) -> dict[str, float]:
    """Part 3: flights per minute of `mfi-drake sweep`: MFI on 1 and 2
    workers, and every method on 2 workers on each engine (the same fields
    for both)."""
    say(
        f"3. sweeps of {fields} fresh fields at density "
        f"{generator.DEFAULT_DENSITY:g}, the whole command (a fresh process, "
        "start-up and the cluster included; the compile cache warm):"
    )
    runs = [
        ("mfi", ["mfi"], 1, "compiled", seed + 1),
        ("mfi", ["mfi"], 2, "compiled", seed + 2),
        ("every method", list(DEFAULT_METHODS), 2, "systems", seed + 3),
        ("every method", list(DEFAULT_METHODS), 2, "compiled", seed + 3),
    ]
    # The cache warm, as after installation: one untimed field of every
    # method (the chains a sweep compiles on the first field it flies),
    # flown here as a sweep's worker flies it: numba's cache on disk is what
    # the sweeps' workers load (no process and cluster of its own to start).
    text = scenario_to_yaml(generator.random_field(seed, 0, generator.DEFAULT_DENSITY))
    reference = field_reference(text)
    for method in DEFAULT_METHODS:
        fly_field(text, method, reference)
    rates = {}
    for label, methods, workers, engine, fields_seed in runs:
        before = load()
        wall, rate = flights_per_minute(workers, fields, fields_seed, methods, engine)
        key = f"{label}, {workers} worker{'s' if workers > 1 else ''}, {engine}"
        rates[key] = rate
        say(
            f"   {key:<38} (seed {fields_seed}): {wall:6.1f} s, "
            f"{rate:6.1f} flights/min ({before} before)"
        )
    gain = (
        rates["every method, 2 workers, compiled"]
        / rates["every method, 2 workers, systems"]
    )
    say(f"   every method on 2 workers, compiled / systems: x{gain:.2f}")
    return rates


def commit() -> str:
    try:
        return subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=PLANAR_WALL)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--duration", type=float, help="override the duration [s]")
    parser.add_argument("--split", type=int, default=8, help="fields of part 2")
    parser.add_argument("--fields", type=int, default=40, help="fields per sweep")
    parser.add_argument("--compare", type=int, default=60, help="fields of part 4")
    parser.add_argument(
        "--seed", type=int, help="first seed of the fresh fields (default: the time)"
    )
    parser.add_argument(
        "--override", help="a `tune` winner file layered on part 4's fields"
    )
    parser.add_argument(
        "--scenarios", default="*.yaml", help="part 5's scenarios (a glob)"
    )
    parser.add_argument("--page", help="a page to write the output into")
    args = parser.parse_args(argv)
    for name in ("repeats", "split", "fields", "compare"):
        if getattr(args, name) < 1:
            parser.error(f"--{name} = {getattr(args, name)}: must be >= 1")
    scenario = load_scenario(args.scenario)
    try:  # read before anything is measured: a bad file costs no run
        layers = [read_override(args.override)] if args.override else []
    except ScenarioError as e:
        parser.error(f"--override: {e}")
    if args.duration is not None:
        if not args.duration > 0.0:
            parser.error(f"--duration = {args.duration}: must be > 0")
        scenario = dataclasses.replace(scenario, duration=args.duration)
    # Fresh fields: no earlier run, and no worker's cache, has seen them.
    seed = args.seed if args.seed is not None else int(time.time()) % 1_000_000
    lines = [f"commit {commit()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}"]

    def say(line: str) -> None:
        lines.append(line)
        print(line, flush=True)

    print(lines[0])
    result = against_cpp(scenario, args.repeats, say)
    result["split"] = split(args.split, seed, say)
    result["rates"] = sweeps(args.fields, seed + 1, say)
    result["methods"] = by_method(args.compare, seed + 3, say)
    if layers:  # the same fields again, each method with its override
        result["overridden"] = by_method(args.compare, seed + 3, say, layers)
    result["scenarios"] = every_scenario(args.scenarios, say)
    if args.page:
        write_section(args.page, "throughput", "```\n" + "\n".join(lines) + "\n```")
    return result


if __name__ == "__main__":
    main()
