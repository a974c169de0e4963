"""The `mfi-drake` command line.

Every command validates its input before anything is simulated: a bad
scenario, override, method or argument is reported as one line on stderr
with exit status 2, and nothing is written. A user's field that fails in
flight is reported as one line too (exit status 1). `run` and `compare`
exit 1 when a flight collided or timed out (0: every flight succeeded),
with their outputs written all the same; each command's --help (built with
`HelpFormatter`, which shows every default) lists its exit statuses.
"""

import argparse
import functools
import json
import math
import os
import subprocess
import sys
import textwrap
import warnings
from collections.abc import Callable
from functools import partial

from mfi_drake.config.scenario import (
    ScenarioError,
    layered_name,
    read_faults,
    read_override,
)
from mfi_drake.flight.methods import METHODS, MethodError, resolve_method
from mfi_drake.systems.navigation import UserFieldError
from mfi_drake.world.validation import (
    ScenarioWarning,
    least_goal_gap,
    load_scenario,
    validate_scenario,
)

EXIT_BAD_INPUT = 2
EXIT_FLIGHT_FAILED = 1


class UsageError(ValueError):
    """A bad command-line argument; reported as one line, exit status 2."""


def _json_safe(obj):
    """Metrics with non-finite floats replaced by None (JSON has no inf)."""
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def summary_line(metrics: dict) -> str:
    """One human line with the outcome and the key numbers of a run; for a
    fleet, its outcome and least separation, then the first vehicle's."""
    outcome = {
        "success": "SUCCESS",
        "collision": "COLLISION",
        "timeout": "NOT REACHED",
    }[metrics["outcome"]]
    clearance = metrics["min_clearance"]
    conv = metrics["convergence_time"]
    fleet = ""
    if "vehicles" in metrics:
        vehicles = metrics["vehicles"]
        fleet = (
            f"fleet of {len(vehicles)}: {sum(v['reached'] for v in vehicles)} "
            f"reached, {sum(v['collided'] for v in vehicles)} collided, least "
            f"separation {metrics['min_separation']:.3f} m; first vehicle: "
        )
    return (
        f"{metrics['scenario']} [{metrics['method']}, {metrics['sensor']}]: {outcome}; "
        f"{fleet}final error {metrics['final_error']:.3f} m, "
        f"min clearance {'n/a' if clearance is None else f'{clearance:.3f} m'}, "
        f"path {metrics['path_length']:.2f} m, "
        f"converged {'never' if conv is None else f'at {conv:.2f} s'}, "
        f"{metrics['sim_time']:.1f} s simulated in {metrics['wall_time']:.2f} s "
        f"({metrics['realtime_factor']:.0f}x real time)"
    )


def overrides(args) -> list[tuple[str, str]]:
    """The --set texts and --override files, in the order given."""
    out = []
    for kind, value in args.overrides or []:
        out.append(
            (f"--set {value!r}", value) if kind == "set" else read_override(value)
        )
    return out


def scenario_of(args):
    """The scenario named on the command line with its overrides, validated."""
    return load_scenario(args.scenario, overrides(args))


def cmd_run(args) -> int:
    from mfi_drake.app.figures import plot_flights
    from mfi_drake.app.flight_log import write_flight_log
    from mfi_drake.flight.simulation import simulate

    _at_least("--processes", args.processes, 1)
    method = resolve_method(args.method)
    scenario = scenario_of(args)
    out = default_out(args.out, scenario.name)
    flight = simulate(scenario, method, processes=args.processes)
    write_flight_log(os.path.join(out, "trajectory.npz"), flight)
    plot_flights(scenario, [flight], os.path.join(out, "trajectory.png"))
    if args.html:
        from mfi_drake.app.animation import write_animation

        write_animation(scenario, [flight], args.html)
    if args.json:
        print(json.dumps(_json_safe(flight.metrics)))
    else:
        print(summary_line(flight.metrics))
        print(f"wrote {out}/trajectory.npz and {out}/trajectory.png")
        if args.html:
            print(f"wrote {args.html}")
    return flights_status([flight])


def default_out(out: str | None, *names: str) -> str:
    """--out, or out/NAMES... where it was not given, checked (`writable`)
    before anything flies."""
    if out is None:
        out = os.path.join("out", *names)
        writable("--out", out, directory=True)
    return out


def flights_status(flights: list) -> int:
    """run's and compare's exit status: 0 when every flight succeeded (reached
    the goal without a collision), else EXIT_FLIGHT_FAILED."""
    return 0 if all(f.metrics["success"] for f in flights) else EXIT_FLIGHT_FAILED


def parse_methods(text: str) -> list[str]:
    """The comma-separated --methods value: distinct names of the registry or
    MODULE:NAME specs, each importable (raises MethodError otherwise)."""
    methods = [m.strip() for m in text.split(",")]
    if not all(methods) or len(set(methods)) < len(methods):
        raise UsageError(
            f"--methods = {text!r}: must be distinct names from {sorted(METHODS)} "
            "or MODULE:NAME, separated by commas"
        )
    for method in methods:
        try:
            resolve_method(method)
        except MethodError as e:
            raise UsageError(f"--methods = {text!r}: {e}") from None
    return methods


def cmd_compare(args) -> int:
    from mfi_drake.app.figures import write_comparison_figure
    from mfi_drake.studies.compare import compare, results_table

    methods = parse_methods(args.methods)
    scenario = scenario_of(args)
    out = default_out(args.out, scenario.name)
    flights = compare(scenario, methods)
    figure = os.path.join(out, "compare.png")
    write_comparison_figure(scenario, flights, figure)
    if args.html:
        from mfi_drake.app.animation import write_animation

        write_animation(scenario, flights, args.html)
    metrics = [f.metrics for f in flights]
    if args.json:
        print(json.dumps(_json_safe({"scenario": scenario.name, "results": metrics})))
    else:
        print(results_table(metrics))
        print(f"wrote {figure}" + (f" and {args.html}" if args.html else ""))
    return flights_status(flights)


def draw_comparison(out: str, name: str, scenario, flights: list) -> None:
    """reproduce's figure of one scenario, drawn where it was flown."""
    from mfi_drake.app.figures import write_comparison_figure

    write_comparison_figure(scenario, flights, os.path.join(out, f"{name}.png"))


def cmd_reproduce(args) -> int:
    from mfi_drake.files import write_text
    from mfi_drake.studies.compare import (
        MFI_VARIANTS,
        PAPER_SCENARIOS,
        claim_verdicts,
        reproduce,
        reproduction_report,
        verdict,
    )

    if not 1 <= args.workers <= len(PAPER_SCENARIOS):
        raise UsageError(
            f"--workers = {args.workers}: must be 1 to {len(PAPER_SCENARIOS)}"
        )
    layers = overrides(args)
    layered = [where for where, _ in layers]
    results = reproduce(
        args.scenarios,
        partial(print, flush=True),
        layers,
        args.workers,
        partial(draw_comparison, args.out),
    )
    for mfi in MFI_VARIANTS:
        print(f"the paper's claims, judged with {METHODS[mfi].label} as MFI:")
        for i, (statement, held, _) in enumerate(claim_verdicts(results, mfi), 1):
            print(f"  {i}. {statement}: {verdict(held)}")
    write_text(
        os.path.join(args.out, "results.md"), reproduction_report(results, layered)
    )
    print(
        f"wrote {args.out}/results.md (the numbers behind each verdict) and one "
        "figure per scenario"
    )
    return 0


def cmd_diagram(args) -> int:
    from mfi_drake.files import atomic_path
    from mfi_drake.flight.diagram import build_diagram

    method = resolve_method(args.method)
    scenario = scenario_of(args)
    if not args.out.endswith(".svg"):
        raise UsageError(f"--out = {args.out!r}: must name a .svg file")
    flight = build_diagram(scenario, method)
    dot = flight.diagram.GetGraphvizString(max_depth=1)
    try:
        svg = subprocess.run(
            ["dot", "-Tsvg"], input=dot.encode(), capture_output=True, check=True
        ).stdout
    except FileNotFoundError:
        raise UsageError(
            "Graphviz `dot` is not installed (apt-get install graphviz)"
        ) from None
    with atomic_path(args.out) as tmp, open(tmp, "wb") as f:
        f.write(svg)
    print(f"wrote {args.out}")
    return 0


def sweep_config(args, **more):
    """(config, tasks) of the random fields the arguments name (seed,
    sensor, vehicles, motion, goal clearance; checked here): a fleet's
    (`studies.fleet_sweep`) where --vehicles > 1. `more`: further fields of
    the configuration."""
    from mfi_drake.studies.fleet_sweep import FLEET, FleetSweepConfig
    from mfi_drake.studies.sweep import SINGLE, SweepConfig

    _check_field_numbers(args)
    _check_motion_numbers(args)
    _at_least("--vehicles", args.vehicles, 1)
    fleet = args.vehicles > 1
    if fleet and args.goal_clearance is not None:
        # random_pairs draws a fleet's goals anew, away from that obstacle.
        raise UsageError(
            f"--goal-clearance = {args.goal_clearance}: places an obstacle near "
            "the one vehicle's goal; not with --vehicles > 1 (a fleet's goals "
            "are drawn anew)"
        )
    config = (FleetSweepConfig if fleet else SweepConfig)(
        **({"vehicles": args.vehicles} if fleet else {}),
        seed=args.seed,
        sensor=args.sensor,
        moving=args.moving,
        obstacle_speed=args.obstacle_speed,
        goal_clearance=args.goal_clearance,
        **more,
    )
    return config, (FLEET if fleet else SINGLE)


# Each kind of `scene` and the options that shape it (the rest: every kind).
SCENE_OPTIONS = {
    "circle": ("radius", "height", "duration"),
    "streams": ("length", "spacing", "height"),
    "field": (
        "seed",
        "density",
        "index",
        "moving",
        "obstacle_speed",
        "goal_clearance",
    ),
}


def cmd_scene(default_of: Callable[[str], object], args) -> int:
    """`default_of`: the scene parser's default of an option (its get_default),
    which tells an option given from one left alone."""
    from dataclasses import replace

    from mfi_drake.studies.sweep import SENSORS
    from mfi_drake.world.fleets import antipodal_circle, crossing_streams
    from mfi_drake.world.generator import write_scenario

    shaping = {name for names in SCENE_OPTIONS.values() for name in names}
    for name in sorted(shaping - set(SCENE_OPTIONS[args.kind])):
        given = getattr(args, name)
        if given != default_of(name):
            kinds = " or ".join(k for k, ns in SCENE_OPTIONS.items() if name in ns)
            flag = "--" + name.replace("_", "-")
            raise UsageError(f"{flag} = {given}: shapes a {kinds} scene only")
    if not args.out.endswith((".yaml", ".yml")):
        raise UsageError(f"--out = {args.out!r}: must name a .yaml file")
    if args.vehicles is None:
        args.vehicles = 1 if args.kind == "field" else 8
    _at_least("--vehicles", args.vehicles, 1)
    for name in ("radius", "length", "spacing", "duration"):
        value = getattr(args, name)
        if value is not None and not (math.isfinite(value) and value > 0.0):
            raise UsageError(f"--{name} = {value}: must be a finite number > 0")
    if args.kind == "field":
        _at_least("--index", args.index, 0)
        config, tasks = sweep_config(args)
        scene = tasks.make_field(config, args.density, args.index)
    else:
        if args.kind == "circle":
            scene = antipodal_circle(
                args.vehicles, args.radius, args.height, args.duration
            )
        else:
            scene = crossing_streams(
                args.vehicles, args.length, args.spacing, args.height
            )
        scene = replace(scene, sensor=SENSORS[args.sensor]())
    validate_scenario(scene, args.out)
    header = f"# written by `mfi-drake scene {args.kind}`; fly it: `mfi-drake run`\n"
    write_scenario(scene, args.out, header=header)
    count = 1 + len(scene.other_vehicles)
    print(f"wrote {args.out}: {scene.name}, {count} vehicle(s), {scene.duration:g} s")
    return 0


def _need_dask() -> None:
    from mfi_drake.studies.sweep import ClusterError, require_dask

    try:
        require_dask()
    except ClusterError as e:
        raise UsageError(str(e)) from None


def cmd_sweep(args) -> int:
    _need_dask()
    from mfi_drake.app.figures import plot_fleet_sweep, plot_sweep
    from mfi_drake.flight.fleet import check_one_integrator
    from mfi_drake.studies.fleet_sweep import FLEET, fleet_table, fleet_variant
    from mfi_drake.studies.sweep import (
        ClusterError,
        dask_client,
        field_to_fly,
        goal_variant,
        layered,
        motion_variant,
        run_sweep,
        summary_table,
        variant_name,
    )

    methods = parse_methods(args.methods) if args.methods else list(METHODS)
    _check_sweep_numbers(args)
    config, tasks = sweep_config(
        args,
        n=args.n,
        methods=methods,
        densities=list(dict.fromkeys(args.density)),
        out=args.out,
    )
    fleet = tasks is FLEET
    if fleet and args.faults is not None:
        raise UsageError(
            f"--faults = {args.faults!r}: not with --vehicles > 1 (a fleet's "
            "vehicles fly without faults)"
        )
    texts = overrides(args)
    faults = None
    if args.faults is not None:
        faults = read_faults(args.faults, f"--faults {args.faults!r}")
    config.variant = variant_name(
        texts,
        faults,
        motion_variant(args.moving, args.obstacle_speed),
        goal_variant(args.goal_clearance),
    )
    if fleet:
        config.variant = fleet_variant(args.vehicles, config.variant)
    modify = partial(layered, overrides=texts, faults=faults)
    # The first field with every layer, checked before a cluster starts or
    # anything is written (run_sweep checks it too, for the API's callers).
    first = field_to_fly(config, tasks, modify, config.densities[0], 0)
    validate_scenario(first, layered_name(first.name, texts))
    check_one_integrator(first, methods)
    try:
        with dask_client(args.workers, args.scheduler, methods) as client:
            run = run_sweep(config, client, modify, tasks=tasks)
    except KeyboardInterrupt:
        print(
            f"mfi-drake: interrupted; finished flights are in {args.out}/results.jsonl,"
            " rerun the same command to fly the rest",
            file=sys.stderr,
        )
        return 130
    except ClusterError as e:  # unreachable, refused, no workers, ...
        raise UsageError(str(e)) from None
    plot = plot_fleet_sweep if fleet else plot_sweep
    plot(run.summary, os.path.join(args.out, "sweep.png"))
    if args.json:
        print(json.dumps(_json_safe(run.summary)))
    else:
        print((fleet_table if fleet else summary_table)(run.summary))
        print(
            f"flew {run.ran}, found {run.skipped} done; wrote {args.out}/: "
            "results.jsonl, summary.json, table.md, sweep.png, failures/"
        )
    for line in run.lost:
        print(f"mfi-drake: not run (rerun to retry): {line}", file=sys.stderr)
    return 1 if run.lost else 0


def _at_least(name: str, value: int | None, least: int) -> None:
    if value is not None and value < least:
        raise UsageError(f"{name} = {value}: must be ≥ {least}")


def _densities(name: str, values: list[float]) -> None:
    for d in values:
        if not (math.isfinite(d) and d >= 0.0):
            raise UsageError(f"{name} = {d}: must be a finite number ≥ 0")


def _check_sweep_numbers(args) -> None:
    _at_least("--n", args.n, 1)
    _at_least("--workers", args.workers, 1)


def _check_field_numbers(args) -> None:
    _at_least("--seed", args.seed, 0)
    several = isinstance(args.density, list)  # sweep's list, scene's one
    _densities("--density", args.density if several else [args.density])
    gap = getattr(args, "goal_clearance", None)
    if gap is not None and not (math.isfinite(gap) and gap >= least_goal_gap()):
        raise UsageError(
            f"--goal-clearance = {gap}: must be a number ≥ {least_goal_gap():.3f} m "
            "(the collision radius plus the goal margin, docs/goals.md)"
        )


def _check_held_out_numbers(args) -> None:
    _at_least("--held-out-seed", args.held_out_seed, 0)
    _at_least("--held-out-n", args.held_out_n, 1)
    _densities("--held-out-density", args.held_out_density)


def _check_motion_numbers(args) -> None:
    if not (math.isfinite(args.moving) and 0.0 <= args.moving <= 1.0):
        raise UsageError(f"--moving = {args.moving}: must be a share in [0, 1]")
    speed = args.obstacle_speed
    if not (math.isfinite(speed) and speed >= 0.0) or (args.moving > 0 and speed == 0):
        raise UsageError(
            f"--obstacle-speed = {speed}: must be a finite number > 0 with --moving"
        )


def cmd_tune(args) -> int:
    _need_dask()
    from mfi_drake.app.figures import plot_sweep
    from mfi_drake.studies.sweep import (
        ClusterError,
        SweepConfig,
        dask_client,
        override_variant,
        run_sweep,
        summary_table,
        with_overrides,
    )
    from mfi_drake.studies.tune import TuneConfig, TuneError, tune

    methods = parse_methods(args.methods)
    _check_sweep_numbers(args)
    _check_field_numbers(args)
    _check_motion_numbers(args)
    _check_held_out_numbers(args)
    config = TuneConfig(
        methods=methods,
        candidates=args.candidates,
        seed=args.seed,
        n=args.n,
        densities=list(dict.fromkeys(args.density)),
        paper_scenarios=args.paper_scenarios,
        walls=args.walls,
        moving=args.moving,
        obstacle_speed=args.obstacle_speed,
        jitter=args.jitter,
        held_out_seed=args.held_out_seed,
        out=args.out,
    )
    try:
        config.check()
    except TuneError as e:
        raise UsageError(str(e)) from None
    if args.held_out_seed is None:
        print(
            "mfi-drake: warning: no --held-out-seed: the tuned gains will not be "
            "flown on held-out fields",
            file=sys.stderr,
        )
    try:
        with dask_client(args.workers, args.scheduler, methods) as client:
            tune(config, client)
            tuned = read_override(os.path.join(args.out, "tuned.yaml"))
            print(f"wrote {args.out}/tuned.yaml, tuning.md, tuning.json, tune.jsonl")
            if args.held_out_seed is None:
                return 0
            held_out = SweepConfig(
                n=args.held_out_n,
                seed=args.held_out_seed,
                methods=methods,
                densities=list(dict.fromkeys(args.held_out_density)),
                out=os.path.join(args.out, "held_out"),
                variant=override_variant([tuned]),
            )
            modify = partial(with_overrides, overrides=[tuned])
            run = run_sweep(held_out, client, modify)
    except (TuneError, ClusterError) as e:
        raise UsageError(str(e)) from None
    plot_sweep(run.summary, os.path.join(held_out.out, "sweep.png"))
    print(summary_table(run.summary))
    print(f"wrote {held_out.out}/ (held-out fields, seed {args.held_out_seed})")
    return 1 if run.lost else 0


def cmd_analyze(args) -> int:
    from mfi_drake.app.analysis_figures import write_analysis_figures
    from mfi_drake.files import write_json
    from mfi_drake.studies.analysis import run_analysis, summary

    scenario = scenario_of(args)
    out = default_out(args.out, scenario.name, "analysis")
    report, series = run_analysis(scenario)
    report["figures"] = write_analysis_figures(series, out)
    report = _json_safe(report)
    write_json(os.path.join(out, "analysis.json"), report)
    if args.json:
        print(json.dumps(report))
    else:
        print(summary(report))
        print(f"wrote {out}/analysis.json and {', '.join(report['figures'])} figures")
    return 0


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Each option's help ends with its default, when it has one to show (an
    option whose default is "absent" says in its help what absent means)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if action.option_strings and action.nargs == 0 and action.default is False:
            return text + " (default: off)"  # a flag
        absent = action.default in (None, argparse.SUPPRESS) or isinstance(
            action.default, bool
        )
        if action.option_strings and not absent and "%(default)" not in text:
            text += " (default: %(default)s)"
        return text


def exit_statuses(done: str, failed: str = "") -> str:
    """The epilog of a command's help: what its exit statuses 0, 1 and 2 mean."""
    rows = [("0", done), ("1", failed), ("2", BAD_INPUT)]
    return "exit status:\n" + "\n".join(
        textwrap.fill(text, 78, initial_indent=f"  {code}  ", subsequent_indent=" " * 5)
        for code, text in rows
        if text
    )


BAD_INPUT = (
    "bad input (a scenario's field, an option's value or an output that "
    "cannot be written), reported as one line naming it before anything is "
    "simulated or written"
)
USER_FIELD_FAILED = "a user's field (MODULE:NAME) raised or returned a bad force"


def add_parser(sub, name: str, help: str, exit_status: str, **kwargs):
    """A subcommand whose help shows every default and its exit statuses."""
    return sub.add_parser(
        name,
        help=help,
        description=textwrap.fill(
            kwargs.pop("description", help[0].upper() + help[1:] + "."), 78
        ),
        epilog=exit_status,
        formatter_class=HelpFormatter,
        **kwargs,
    )


def add_motion(parser: argparse.ArgumentParser, what: str) -> None:
    """--moving and --obstacle-speed (`generator.set_in_motion`)."""
    parser.add_argument(
        "--moving",
        type=float,
        default=0.0,
        metavar="SHARE",
        help=f"{what}, in [0, 1], circling at --obstacle-speed (0: none; "
        "docs/dynamic.md)",
    )
    parser.add_argument(
        "--obstacle-speed",
        type=float,
        default=0.0,
        metavar="M/S",
        help="speed of the moving obstacles, ≥ 0; > 0 with --moving",
    )


def add_random_field(parser: argparse.ArgumentParser, several: bool) -> None:
    """The options of sweep's random fields (`sweep_config`): --seed,
    --density (`several`: a list of them), --sensor, --moving,
    --obstacle-speed, --goal-clearance."""
    from mfi_drake.world.generator import DEFAULT_DENSITY

    parser.add_argument(
        "--seed",
        metavar="S",
        type=int,
        default=0,
        help="seed of the random fields, ≥ 0",
    )
    box = "obstacles per m³ of the 8×5×5 m box around the start–goal line"
    parser.add_argument(
        "--density",
        metavar="D",
        type=float,
        nargs="+" if several else None,
        default=[DEFAULT_DENSITY] if several else DEFAULT_DENSITY,
        help=f"{box}, each ≥ 0; several values sweep them all"
        if several
        else f"{box}, ≥ 0",
    )
    parser.add_argument(
        "--sensor",
        choices=["sphere", "depth"],
        default="sphere",
        help="the sensor every vehicle flies with: the paper's sensing sphere "
        "or the depth camera (docs/depth_camera.md)",
    )
    add_motion(parser, "share of each field's obstacles that move")
    parser.add_argument(
        "--goal-clearance",
        type=float,
        metavar="M",
        help="add to each field an obstacle whose surface is M metres from the "
        "goal (a random kind, in a random direction; docs/goals.md); at least "
        "the collision radius plus the goal margin (default: none)",
    )


def add_overrides(parser: argparse.ArgumentParser) -> None:
    """--set and --override, layered on the scenario in the order given."""
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        type=lambda text: ("set", text),
        metavar="YAML",
        help="scenario fields layered on top, e.g. 'faults: {sensor_noise_std: "
        "0.05}'; repeatable, applied in order with --override (default: none)",
    )
    parser.add_argument(
        "--override",
        dest="overrides",
        action="append",
        type=lambda path: ("file", path),
        metavar="FILE",
        help="a YAML file of scenario fields layered on top, e.g. tune's "
        "tuned.yaml; repeatable (default: none, the scenario's own gains)",
    )


def add_flight_outputs(parser: argparse.ArgumentParser, json_help: str) -> None:
    """--out, --json and --html of run and compare."""
    parser.add_argument(
        "--out", metavar="DIR", help="output directory (default: out/<scenario name>)"
    )
    parser.add_argument("--json", action="store_true", help=json_help)
    parser.add_argument(
        "--html",
        metavar="FILE.html",
        help="also write a standalone Meshcat animation to this .html file "
        "(default: none)",
    )


def add_field_count(parser: argparse.ArgumentParser, n: int, what: str) -> None:
    """--n, checked by `_check_sweep_numbers`."""
    parser.add_argument(
        "--n", type=int, default=n, help=f"{what} fields per density, ≥ 1"
    )


def add_workers(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--workers",
        metavar="K",
        type=int,
        default=os.cpu_count() or 1,
        help="local Dask worker processes, ≥ 1 (default: %(default)s, one per core)",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="address of a running Dask scheduler, e.g. tcp://host:8786, "
        "used instead of local workers (default: none)",
    )


def make_parser() -> argparse.ArgumentParser:
    from mfi_drake.studies.compare import PAPER_SCENARIOS
    from mfi_drake.studies.tune import JITTER_AXES, MIN_CANDIDATES

    parser = argparse.ArgumentParser(
        prog="mfi-drake",
        description="Magnetic-field-inspired quadcopter navigation on Drake.",
        epilog="Each command's --help lists its options with their defaults and "
        f"what its exit statuses mean; {EXIT_BAD_INPUT} is always bad input.",
        formatter_class=HelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True)
    methods = ", ".join(METHODS)

    run = add_parser(
        sub,
        "run",
        "fly a scenario and write its log and figure",
        exit_statuses(
            "the flight succeeded: it reached the goal without a collision",
            "the flight collided or timed out (the log and figure are written "
            f"all the same), or {USER_FIELD_FAILED}",
        ),
    )
    run.add_argument("scenario", help="scenario YAML file")
    add_overrides(run)
    run.add_argument(
        "--method",
        metavar="M",
        default="mfi",
        help=f"one of {methods}, or MODULE:NAME of your own field function",
    )
    run.add_argument(
        "--processes",
        metavar="P",
        type=int,
        default=1,
        help="with other_vehicles: processes the fleet's vehicles are spread "
        "over, ≥ 1 (the same flights, sooner on several cores; at most one "
        "per vehicle is used)",
    )
    add_flight_outputs(run, "print the flight's metrics as one JSON object")
    run.set_defaults(func=cmd_run)

    comp = add_parser(
        sub,
        "compare",
        "fly a scenario with several methods",
        exit_statuses(
            "every method's flight succeeded",
            "a method's flight collided or timed out (every method is flown "
            f"and written all the same), or {USER_FIELD_FAILED}",
        ),
    )
    comp.add_argument("scenario", help="scenario YAML file")
    add_overrides(comp)
    comp.add_argument(
        "--methods",
        metavar="M,M,...",
        default=",".join(METHODS),
        help="distinct names or MODULE:NAME, separated by commas",
    )
    add_flight_outputs(comp, "print every method's metrics as one JSON object")
    comp.set_defaults(func=cmd_compare)

    rep = add_parser(
        sub,
        "reproduce",
        "the paper's §VI-A comparison: figures and results.md",
        description="Flies the paper's four scenarios (planar_wall, "
        "three_spheres, tree, sharp_corner) with every method and judges the "
        "paper's four claims, with the scenarios' own (shipped) gains unless "
        "--override or --set layers others on, e.g. tune's tuned.yaml.",
        exit_status=exit_statuses(
            "results.md and the figures are written, whatever the flights' "
            "outcomes and whether or not each claim held (the verdicts are the "
            "output)"
        ),
    )
    rep.add_argument(
        "--scenarios",
        metavar="DIR",
        default="scenarios",
        help="directory holding the paper's scenarios (planar_wall.yaml, ...)",
    )
    rep.add_argument(
        "--out", metavar="DIR", default="out/reproduce", help="output directory"
    )
    add_overrides(rep)
    rep.add_argument(
        "--workers",
        metavar="K",
        type=int,
        default=min(len(PAPER_SCENARIOS), os.cpu_count() or 1),
        help="processes flying the scenarios at once, 1 to "
        f"{len(PAPER_SCENARIOS)} (default: %(default)s, one per core, at most "
        f"{len(PAPER_SCENARIOS)})",
    )
    rep.set_defaults(func=cmd_reproduce)

    sweep = add_parser(
        sub,
        "sweep",
        "Monte Carlo benchmark on random obstacle fields (Dask)",
        exit_status=exit_statuses(
            "every flight was flown, whatever its outcome (the rates are the output)",
            "a flight could not be run (rerun the same command to fly it)",
        ),
    )
    add_overrides(sweep)
    add_field_count(sweep, 30, "random")
    sweep.add_argument(
        "--methods",
        metavar="M,M,...",
        help="distinct names or MODULE:NAME, separated by commas, e.g. mfi,apf,gf "
        f"(default: every method of the registry: {','.join(METHODS)})",
    )
    add_random_field(sweep, several=True)
    sweep.add_argument(
        "--vehicles",
        metavar="V",
        type=int,
        default=1,
        help="vehicles per field, ≥ 1, between random start and goal pairs at the "
        "ends of the box, half each way (1: the single-vehicle sweep)",
    )
    add_workers(sweep)
    sweep.add_argument(
        "--faults",
        metavar="YAML",
        help="a scenario `faults:` block flown on every field, as YAML, e.g. "
        "'{sensor_noise_std: 0.05, dropout_prob: 0.1}' (each field's seed is "
        "offset by its name); results are keyed by it, so several can share "
        "--out (default: none)",
    )
    sweep.add_argument(
        "--out", metavar="DIR", default="out/sweep", help="output directory"
    )
    sweep.add_argument(
        "--json", action="store_true", help="print the summary as one JSON object"
    )
    sweep.set_defaults(func=cmd_sweep)

    scene = add_parser(
        sub,
        "scene",
        "write a scenario file of N vehicles: an antipodal circle, crossing "
        "streams, or a sweep's random field",
        exit_statuses("the scenario is written, validated as `run` would"),
        description="Writes a scenario file of N vehicles, validated as `run` "
        "would, with every obstacle inline: 'circle' puts them evenly on a "
        "horizontal circle, each flying to the opposite point (all meet in the "
        "middle); 'streams' makes two streams abreast crossing at right angles; "
        "'field' is the random field `sweep` flies for --seed, --density, "
        "--index and --vehicles (1: the single-vehicle sweep's field). Options "
        "that shape another kind are refused. Fly it with `mfi-drake run FILE`.",
    )
    scene.add_argument("kind", choices=list(SCENE_OPTIONS), help="the kind of scene")
    scene.add_argument(
        "--vehicles",
        metavar="V",
        type=int,
        help="vehicles, ≥ 1 (default: 8; 1 for field)",
    )
    scene.add_argument(
        "--radius",
        type=float,
        metavar="M",
        help="circle: its radius, > 0 (default: 6 m, or wider so that "
        "neighbours are 2 m apart along it)",
    )
    scene.add_argument(
        "--duration",
        type=float,
        metavar="T",
        help="circle: simulated seconds, > 0 (default: 5 s per metre of diameter)",
    )
    scene.add_argument(
        "--height", type=float, default=2.0, metavar="M", help="circle, streams: z"
    )
    scene.add_argument(
        "--length",
        type=float,
        default=12.0,
        metavar="M",
        help="streams: each vehicle's start–goal distance, > 0",
    )
    scene.add_argument(
        "--spacing",
        type=float,
        default=1.5,
        metavar="M",
        help="streams: between neighbours abreast, > 0",
    )
    add_random_field(scene, several=False)
    scene.add_argument(
        "--index",
        metavar="I",
        type=int,
        default=0,
        help="field: which field of the seed, ≥ 0",
    )
    scene.add_argument(
        "--out", metavar="FILE.yaml", required=True, help="the .yaml file to write"
    )
    scene.set_defaults(func=partial(cmd_scene, scene.get_default), out_is_file=True)

    diagram = add_parser(
        sub,
        "diagram",
        "draw the built diagram as SVG (Graphviz)",
        exit_statuses("the .svg is written"),
    )
    diagram.add_argument("scenario", help="scenario YAML file")
    add_overrides(diagram)
    diagram.add_argument(
        "--method",
        metavar="M",
        default="mfi",
        help=f"one of {methods}, or MODULE:NAME of your own field function",
    )
    diagram.add_argument(
        "--out", metavar="FILE.svg", required=True, help="output .svg file (required)"
    )
    diagram.set_defaults(func=cmd_diagram, out_is_file=True)

    tune = add_parser(
        sub,
        "tune",
        "one tuning protocol for every method, then held-out fields (Dask)",
        exit_status=exit_statuses(
            "tuned.yaml and, with --held-out-seed, the held-out sweep are written",
            "a held-out flight could not be run (rerun the same command to fly it)",
        ),
    )
    tune.add_argument(
        "--methods",
        metavar="M,M,...",
        default=",".join(METHODS),
        help="distinct names or MODULE:NAME, separated by commas",
    )
    tune.add_argument(
        "--candidates",
        metavar="C",
        type=int,
        default=24,
        help=f"gain sets tried per method, ≥ {MIN_CANDIDATES}: the current gains, "
        "a Latin hypercube of two thirds of the rest, then two rounds of "
        "refinement; the budget is candidates × training fields flights",
    )
    tune.add_argument(
        "--seed", metavar="S", type=int, default=100, help="training fields' seed, ≥ 0"
    )
    add_field_count(tune, 10, "random training")
    tune.add_argument(
        "--density",
        metavar="D",
        type=float,
        nargs="+",
        default=[0.1, 0.2],
        help="training densities, obstacles per m³, each ≥ 0",
    )
    tune.add_argument(
        "--paper-scenarios",
        metavar="DIR",
        help="a directory whose paper scenarios join training (default: none)",
    )
    tune.add_argument(
        "--walls",
        metavar="W",
        type=int,
        default=0,
        help="wall fields that join training, ≥ 0",
    )
    add_motion(tune, "each random training field also flown with this share moving")
    tune.add_argument(
        "--jitter",
        metavar="J",
        type=int,
        default=1,
        help="fly each random training field this many times, started 1 mm "
        f"apart, 1 (once) to {1 + len(JITTER_AXES)}",
    )
    tune.add_argument(
        "--held-out-seed",
        metavar="H",
        type=int,
        help="seed of the held-out fields the winners are then flown on, ≥ 0 and "
        "≠ --seed (default: none, no held-out phase, with a warning)",
    )
    tune.add_argument(
        "--held-out-n",
        metavar="N",
        type=int,
        default=200,
        help="held-out fields per density, ≥ 1",
    )
    tune.add_argument(
        "--held-out-density",
        metavar="D",
        type=float,
        nargs="+",
        default=[0.05, 0.1, 0.2],
        help="held-out densities, obstacles per m³, each ≥ 0",
    )
    add_workers(tune)
    tune.add_argument(
        "--out", metavar="DIR", default="out/tune", help="output directory"
    )
    tune.set_defaults(func=cmd_tune)

    analyze = add_parser(
        sub,
        "analyze",
        "linearisation, stability and region of attraction (MFI)",
        exit_statuses("analysis.json and the figures are written"),
    )
    analyze.add_argument("scenario", help="scenario YAML file")
    add_overrides(analyze)
    analyze.add_argument(
        "--out",
        metavar="DIR",
        help="output directory (default: out/<scenario name>/analysis)",
    )
    analyze.add_argument(
        "--json", action="store_true", help="print the report as one JSON object"
    )
    analyze.set_defaults(func=cmd_analyze)
    return parser


def _check_html(args) -> None:
    html = getattr(args, "html", None)
    if html is not None and not html.endswith(".html"):
        raise UsageError(f"--html = {html!r}: must name a .html file")


def writable(flag: str, path: str, directory: bool) -> None:
    """Raises UsageError, before anything is flown, where `path` (a directory
    to create or fill, or a file to write) cannot be written: a file where a
    directory must be or the reverse, or an existing ancestor that is not a
    writable directory."""
    if not path:
        kind = "directory" if directory else "file"
        raise UsageError(f"{flag} = '': must name a {kind}")
    if directory and os.path.lexists(path) and not os.path.isdir(path):
        raise UsageError(f"{flag} = {path!r}: is a file, not a directory")
    if not directory and os.path.isdir(path):
        raise UsageError(f"{flag} = {path!r}: is a directory")
    ancestor = os.path.abspath(path if directory else os.path.dirname(path) or ".")
    while not os.path.lexists(ancestor):
        ancestor = os.path.dirname(ancestor)
    if not os.path.isdir(ancestor):
        raise UsageError(f"{flag} = {path!r}: {ancestor} is not a directory")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise UsageError(f"{flag} = {path!r}: {ancestor} is not writable")


def _check_outputs(args) -> None:
    if getattr(args, "out", None) is not None:
        writable("--out", args.out, not getattr(args, "out_is_file", False))
    if getattr(args, "html", None) is not None:
        writable("--html", args.html, directory=False)


def _one_line_warnings(command: Callable[..., int]) -> Callable[..., int]:
    """`command` showing a scenario's warnings as the one line the user
    reads (others as before)."""

    @functools.wraps(command)
    def wrapped(*args, **kwargs) -> int:
        with warnings.catch_warnings():
            shown = warnings.showwarning

            def show(message, category, *more, **options) -> None:
                if issubclass(category, ScenarioWarning):
                    print(f"mfi-drake: warning: {message}", file=sys.stderr)
                else:
                    shown(message, category, *more, **options)

            warnings.showwarning = show
            return command(*args, **kwargs)

    return wrapped


@_one_line_warnings
def main(argv: list[str] | None = None) -> int:
    args = make_parser().parse_args(argv)
    try:
        _check_html(args)
        _check_outputs(args)
        return args.func(args)
    except MethodError as e:
        print(f"mfi-drake: error: --method = {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (ScenarioError, UsageError) as e:
        print(f"mfi-drake: error: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except UserFieldError as e:
        print(f"mfi-drake: error: {e}", file=sys.stderr)
        return EXIT_FLIGHT_FAILED
    except OSError as e:  # an output that passed `writable` and still failed
        where = f"{e.filename}: {e.strerror}" if e.filename else str(e)
        print(f"mfi-drake: error: {where}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
