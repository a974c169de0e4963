"""`mfi-drake tune`: one tuning protocol for every method.

The protocol, the same for every method and fixed before any result is seen:

1. Training fields: `n` random fields per density at the training seed
   (`world.generator`), optionally with `walls` wall fields of that seed
   (one long wall across the line: structure the random fields lack) and
   the paper's scenarios added, and with `moving` > 0 each random field a
   second time with that share of its obstacles circling at
   `obstacle_speed` (`generator.set_in_motion`, as `sweep --moving`): the
   closing speeds that static fields lack. With `jitter` = K > 1, each
   random field (in motion too) is flown K times, the copies starting
   JITTER_STEP (1 mm) away along +x, −x, +y, −y, +z, −z in turn: a dense
   field can be a coin flip, its outcome turned by a millimetre (training
   seed 100, field 70 at 0.2), and K copies count it as the share of them
   that fail instead of as all or nothing. Every method flies exactly
   these fields.
2. Search over the method's documented free gains (`methods.Gain`), in the
   unit cube of their ranges (log-uniform where a gain is a scale):
   candidate 0 is the method's current defaults; then a Latin hypercube of
   two thirds of the remaining candidates; then local refinement in two
   rounds, each sampling Gaussian steps (σ = 0.15, then 0.07 of the range)
   around the best candidate so far. Every method gets the same number of
   candidates, so the same budget of flights: candidates × fields.
3. Objective, lexicographic: most successes, then fewest collisions, then
   the smallest mean path ratio (path / shortest path, to 0.001) over the
   successful flights, then the smallest mean convergence time (to 0.01 s).
4. The winners are written as one scenario override file (`tuned.yaml`),
   which run, compare and sweep accept with `--override`; each method's
   gains live in its own scenario field, so one file serves every method.
5. Held-out evaluation: the winners flown on fields of a seed that is not a
   training seed (refused otherwise), through the sweep (`held_out_sweep`):
   random fields, or with `held_out_world` the sweep's generated non-convex
   worlds of that seed (a class of `world.nonconvex`, or every class).

From Python, `tune_held_out` runs all five steps; `mfi-drake tune` runs
`tune`, then `held_out_sweep` where a held-out seed is given.

Flights run on Dask like the sweep (`cluster.run_tasks`, on a local or a
remote cluster; every field self-contained, the paper's scenarios with
their meshes inline) and are appended to DIR/tune.jsonl as they finish; a
rerun with the same arguments flies only what is missing (the candidates
are a deterministic function of the seed and of the results already
recorded).
"""

import dataclasses
import math
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.scenario_yaml import read_override, scenario_to_yaml
from mfi_drake.files import write_json, write_text
from mfi_drake.flight.fleet import on_compiled
from mfi_drake.flight.methods import Method, resolve_method
from mfi_drake.studies.cluster import ClusterError, Task, run_tasks
from mfi_drake.studies.compare import PAPER_SCENARIOS
from mfi_drake.studies.records import RANDOM, ResultsFile, read_results
from mfi_drake.studies.sweep import (
    SINGLE,
    WORLDS,
    SweepConfig,
    SweepRun,
    default_engine,
    field_reference,
    fly_field,
    make_field,
    run_sweep,
)
from mfi_drake.studies.tune_search import (
    Candidate,
    current_values,
    gain_values,
    latin_hypercube,
    override_text,
    score,
    unit_point,
)
from mfi_drake.studies.variants import override_variant, with_overrides
from mfi_drake.world.generator import self_contained, set_in_motion, wall_field
from mfi_drake.world.validation import load_scenario

REFINE_SIGMAS = (0.15, 0.07)  # of the unit range, one per refinement round
JITTER_STEP = 1e-3  # [m] how far a jittered copy of a field starts from its own
JITTER_AXES = ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1))
# Fewest candidates per method: the current gains and two Latin-hypercube points.
MIN_CANDIDATES = 3
# The held-out sweep's fields per density, and its densities (step 5).
HELD_OUT_N = 200
HELD_OUT_DENSITIES = (0.05, 0.1, 0.2)


class TuneError(ValueError):
    """Tuning that cannot start (overlapping seeds, a method without gains)."""


@dataclass
class TuneConfig:
    methods: list[str]
    candidates: int = 24  # per method: the budget is candidates × fields
    seed: int = 100  # training fields' seed; also seeds the search
    n: int = 10  # training fields per density
    densities: list[float] = field(default_factory=lambda: [0.1, 0.2])
    paper_scenarios: str | None = None  # a directory: its paper scenarios join
    walls: int = 0  # wall fields (`generator.wall_field`) that join training
    moving: float = 0.0  # > 0: each random field also flown with this share moving
    obstacle_speed: float = 0.0  # [m/s] of the moving obstacles
    jitter: int = 1  # copies of each random field, started 1 mm apart
    held_out_seed: int | None = None  # fields never used for training
    # What the held-out phase flies: random fields, or generated worlds
    # (a class of `world.nonconvex`, or NONCONVEX: every class), as `sweep --world`.
    held_out_world: str = RANDOM
    out: str = "out/tune"

    def check(self) -> None:
        if self.held_out_seed is not None and self.held_out_seed == self.seed:
            raise TuneError(
                f"--held-out-seed = {self.held_out_seed}: the held-out fields must "
                f"not overlap the training fields (--seed = {self.seed})"
            )
        if self.walls < 0:
            raise TuneError(f"--walls = {self.walls}: must be ≥ 0")
        if self.held_out_world not in WORLDS:
            raise TuneError(
                f"--held-out-world = {self.held_out_world}: must be one of "
                f"{', '.join(WORLDS)}"
            )
        if self.candidates < MIN_CANDIDATES:
            raise TuneError(
                f"--candidates = {self.candidates}: must be ≥ {MIN_CANDIDATES}"
            )
        if not 1 <= self.jitter <= 1 + len(JITTER_AXES):
            raise TuneError(
                f"--jitter = {self.jitter}: must be 1 (none) to "
                f"{1 + len(JITTER_AXES)} (the field and one copy per axis direction)"
            )


# --- the run ------------------------------------------------------------------------
def training_fields(config: TuneConfig) -> list[Scenario]:
    """The sweep's fields of the training seed, the same in motion, its wall
    fields and the paper's scenarios, each if asked for; all
    self-contained."""
    like = SweepConfig(n=config.n, seed=config.seed, out=config.out)
    grid = [(d, index) for d in config.densities for index in range(config.n)]
    fields = [make_field(like, density, index) for density, index in grid]
    if config.moving > 0.0:
        fields += [
            dataclasses.replace(
                set_in_motion(
                    field, config.seed, index, config.moving, config.obstacle_speed
                ),
                name=f"{field.name}_moving",
            )
            for field, (_, index) in zip(fields, grid, strict=True)
        ]
    fields += [
        jittered(field, axis)
        for field in list(fields)
        for axis in JITTER_AXES[: config.jitter - 1]
    ]
    fields += [wall_field(config.seed, index) for index in range(config.walls)]
    if config.paper_scenarios:
        fields += [
            self_contained(
                load_scenario(os.path.join(config.paper_scenarios, f"{name}.yaml"))
            )
            for name in PAPER_SCENARIOS
        ]
    return fields


def jittered(field: Scenario, axis: tuple[int, int, int]) -> Scenario:
    """`field` started JITTER_STEP along `axis` from its own start, named
    after both (its obstacles, goal and all else the same)."""
    start = [s + JITTER_STEP * a for s, a in zip(field.start, axis, strict=True)]
    sign = "".join(f"{a:+d}" for a in axis)
    return dataclasses.replace(field, start=start, name=f"{field.name}_jitter{sign}")


def tune(
    config: TuneConfig, client, progress_stream=sys.stderr
) -> dict[str, Candidate]:
    """Tunes every method of `config` on the Dask `client`; returns the best
    candidate of each and writes DIR/tune.jsonl, DIR/tuned.yaml and
    DIR/tuning.md."""
    config.check()
    methods = {name: resolve_method(name) for name in config.methods}
    for method in methods.values():
        if not method.gains:
            raise TuneError(f"--methods: {method.name!r} declares no free gains")
    results_path = os.path.join(config.out, "tune.jsonl")
    done = read_results(results_path)
    fields = training_fields(config)
    texts = {s.name: scenario_to_yaml(s) for s in fields}
    references: dict[str, dict] = {}
    _run(
        client,
        [
            (name, Task(f"tune-reference-{name}", field_reference, (text,)))
            for name, text in texts.items()
        ],
        references.__setitem__,
        config.methods,
    )
    best = {}
    with ResultsFile(results_path) as results:
        for name, method in methods.items():
            mine = [r for r in done if r["method"] == name]
            best[name] = _tune_method(
                config, client, method, fields, texts, references, mine,
                results.append,
                progress_stream,
            )  # fmt: skip
    write_text(
        os.path.join(config.out, "tuned.yaml"),
        _tuned_yaml(config, {n: c.values for n, c in best.items()}),
    )
    write_json(
        os.path.join(config.out, "tuning.json"),
        {
            "config": dataclasses.asdict(config),
            "fields": [s.name for s in fields],
            "best": {n: c.summary() for n, c in best.items()},
        },
    )
    write_text(os.path.join(config.out, "tuning.md"), tuning_table(config, best))
    return best


def held_out_sweep(
    config: TuneConfig,
    client,
    n: int = HELD_OUT_N,
    densities: Sequence[float] = HELD_OUT_DENSITIES,
    progress_stream=sys.stderr,
) -> SweepRun:
    """Step 5 of the protocol: the winners of DIR/tuned.yaml (written by
    `tune`) flown by every method of `config` on `n` random fields per
    density of `densities` at `config.held_out_seed` (or, with
    `config.held_out_world`, `n` generated worlds of each class, densities
    unused), through the sweep (`run_sweep`, its files in DIR/held_out/,
    its records keyed by the override's variant). Raises TuneError where
    the held-out seed is None or a training seed."""
    config.check()
    if config.held_out_seed is None:
        raise TuneError("held_out_seed = None: no held-out fields to fly")
    tuned = read_override(os.path.join(config.out, "tuned.yaml"))
    held_out = SweepConfig(
        n=n,
        seed=config.held_out_seed,
        methods=list(config.methods),
        densities=list(dict.fromkeys(densities))
        if config.held_out_world == RANDOM
        else [],
        out=os.path.join(config.out, "held_out"),
        variant=override_variant([tuned]),
        world=config.held_out_world,
    )
    modify = partial(with_overrides, overrides=[tuned])
    modify = default_engine(held_out, SINGLE, modify)
    return run_sweep(held_out, client, modify, progress_stream)


def tune_held_out(
    config: TuneConfig,
    client,
    n: int = HELD_OUT_N,
    densities: Sequence[float] = HELD_OUT_DENSITIES,
    progress_stream=sys.stderr,
) -> tuple[dict[str, Candidate], SweepRun | None]:
    """The whole protocol (the module docstring) on the Dask `client`:
    `tune`, then, where `config.held_out_seed` is set, `held_out_sweep` of
    `n` fields per density of `densities`. Returns (the best candidate of
    each method, the held-out sweep's run or None); the files are those of
    `mfi-drake tune` with the same arguments."""
    best = tune(config, client, progress_stream)
    if config.held_out_seed is None:
        return best, None
    return best, held_out_sweep(config, client, n, densities, progress_stream)


def _tune_method(
    config: TuneConfig,
    client,
    method: Method,
    fields: list[Scenario],
    texts: dict[str, str],
    references: dict,
    done: list[dict],
    record: Callable[[dict], None],
    progress_stream,
) -> Candidate:
    gains = method.gains
    rng = np.random.default_rng([config.seed, len(gains)])
    rest = config.candidates - 1
    first = math.ceil(2 * rest / 3)
    rounds = [first] + _split(rest - first, len(REFINE_SIGMAS))
    candidates = [Candidate(0, current_values(fields[0], gains))]
    for unit in latin_hypercube(rng, first, len(gains)):
        candidates.append(Candidate(len(candidates), gain_values(gains, unit)))
    evaluated: list[Candidate] = []
    for k, count in enumerate(rounds):
        batch = candidates if k == 0 else []
        if k > 0:  # refine around the best so far
            centre = unit_point(gains, max(evaluated, key=_key).values)
            for _ in range(count):
                step = rng.normal(0.0, REFINE_SIGMAS[k - 1], len(gains))
                unit = np.clip(centre + step, 0.0, 1.0)
                index = len(evaluated) + len(batch)
                batch.append(Candidate(index, gain_values(gains, unit)))
        _evaluate(client, method, batch, fields, texts, references, done, record)
        evaluated += batch
        if progress_stream is not None:
            best = max(evaluated, key=_key).summary()
            progress_stream.write(
                f"{method.name}: round {k + 1}/{len(rounds)}, "
                f"{len(evaluated)} candidates, best {best['successes']}/"
                f"{len(fields)} successes, {best['collisions']} collisions\n"
            )
    return max(evaluated, key=_key)


def _key(candidate: Candidate) -> tuple:
    # Ties (equal scores) go to the earlier candidate: the defaults first.
    return (*score(candidate.records), -candidate.index)


def _split(total: int, parts: int) -> list[int]:
    return [total // parts + (i < total % parts) for i in range(parts)]


def _evaluate(client, method, batch, fields, texts, references, done, record):
    """Flies every candidate of `batch` on every field (those not already in
    `done`), filling each candidate's records."""
    known = {(r["candidate"], r["scenario"]): r for r in done}
    tasks = []
    for candidate in batch:
        override = override_text(candidate.values)
        for scenario in fields:
            key = (candidate.index, scenario.name)
            if key in known and known[key]["gains"] == candidate.values:
                candidate.records.append(known[key])
                continue
            layered = with_overrides(scenario, [("tune", override)])
            layered = on_compiled(layered, [method.name]) or layered
            task = Task(
                f"tune-{method.name}-{candidate.index}-{scenario.name}",
                fly_field,
                (scenario_to_yaml(layered), method.name, references[scenario.name]),
            )
            tasks.append((candidate, task))

    def on_result(candidate: Candidate, result: dict) -> None:
        result = (
            {"method": method.name, "candidate": candidate.index}
            | {"gains": candidate.values}
            | result
        )
        record(result)
        candidate.records.append(result)

    _run(client, tasks, on_result, [method.name])


def _run(client, tasks, on_result, methods) -> None:
    """`cluster.run_tasks`; a lost task stops the tuning (a rerun resumes)."""
    lost = run_tasks(client, tasks, on_result, methods)
    if lost:
        raise ClusterError(
            f"{len(lost)} tasks lost ({lost[0]}); rerun the same command to resume"
        )


def _tuned_yaml(config: TuneConfig, winners: dict[str, dict[str, float]]) -> str:
    merged: dict[str, float] = {}
    for values in winners.values():
        merged |= values
    header = (
        f"# Written by `mfi-drake tune` (seed {config.seed}, {config.n} fields per "
        f"density {config.densities}, {config.candidates} candidates per method):\n"
        f"# the winning gains of {', '.join(winners)}. Use with --override.\n"
    )
    return header + override_text(merged) + "\n"


def tuning_table(config: TuneConfig, best: dict[str, Candidate]) -> str:
    lines = [
        "# Tuning (training fields only)",
        "",
        f"Written by `mfi-drake tune`: {config.candidates} candidates per method, "
        f"each flown on the same {len(next(iter(best.values())).records)} training "
        f"fields (seed {config.seed}, densities {config.densities}"
        + (
            f", each also with {config.moving:.0%} of its obstacles circling at "
            f"{config.obstacle_speed:g} m/s"
            if config.moving
            else ""
        )
        + (
            f", each random field {config.jitter} times, started 1 mm apart"
            if config.jitter > 1
            else ""
        )
        + (f", plus {config.walls} wall fields" if config.walls else "")
        + (", plus the paper's scenarios" if config.paper_scenarios else "")
        + ").",
        "",
        "| method | successes | collisions | mean path ratio | gains |",
        "|---|---|---|---|---|",
    ]
    for name, candidate in best.items():
        s = candidate.summary()
        ratio = s["mean_path_ratio"]
        gains = ", ".join(f"{k} = {v:.4g}" for k, v in s["gains"].items())
        lines.append(
            f"| {name} | {s['successes']}/{s['flights']} | {s['collisions']} "
            f"| {'–' if ratio is None else f'{ratio:.3f}'} | {gains} |"
        )
    return "\n".join(lines) + "\n"
