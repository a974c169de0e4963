"""The `mfi-drake` command line.

Every command validates its input before anything is simulated: a bad
scenario, override, method or argument is reported as one line on stderr
with exit status 2, and nothing is written. A user's field that fails in
flight is reported as one line too (exit status 1).
"""

import argparse
import json
import math
import os
import subprocess
import sys
from functools import partial

from mfi_drake.config.scenario import ScenarioError, read_override
from mfi_drake.flight.methods import METHODS, MethodError, resolve_method
from mfi_drake.systems.navigation import UserFieldError
from mfi_drake.world.validation import load_scenario

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
    """One human line with the outcome and the key numbers of a run."""
    outcome = {
        "success": "SUCCESS",
        "collision": "COLLISION",
        "timeout": "NOT REACHED",
    }[metrics["outcome"]]
    clearance = metrics["min_clearance"]
    conv = metrics["convergence_time"]
    return (
        f"{metrics['scenario']} [{metrics['method']}, {metrics['sensor']}]: {outcome}; "
        f"final error {metrics['final_error']:.3f} m, "
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

    method = resolve_method(args.method)
    scenario = scenario_of(args)
    out = args.out or os.path.join("out", scenario.name)
    flight = simulate(scenario, method)
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
    return 0


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
    out = args.out or os.path.join("out", scenario.name)
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
    return 0


def cmd_reproduce(args) -> int:
    from mfi_drake.app.figures import write_comparison_figure
    from mfi_drake.files import write_text
    from mfi_drake.studies.compare import reproduce, reproduction_report

    layers = overrides(args)
    results, flights = reproduce(args.scenarios, overrides=layers)
    for name, flown in flights.items():
        figure = os.path.join(args.out, f"{name}.png")
        write_comparison_figure(flown[0].scenario, flown, figure)
    report = reproduction_report(results, [where for where, _ in layers])
    write_text(os.path.join(args.out, "results.md"), report)
    print(f"wrote {args.out}/results.md and one figure per scenario")
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


def _need_dask() -> None:
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise UsageError(
            "sweep and tune need Dask distributed: pip install 'mfi_drake[sweep]'"
        ) from None


def cmd_sweep(args) -> int:
    _need_dask()
    from mfi_drake.app.figures import plot_sweep
    from mfi_drake.config.faults import faults_from_yaml
    from mfi_drake.studies.fleet_sweep import (
        FLEET,
        FleetSweepConfig,
        fleet_table,
        fleet_variant,
    )
    from mfi_drake.studies.sweep import (
        SweepConfig,
        dask_client,
        layered,
        motion_variant,
        run_sweep,
        summary_table,
        variant_name,
    )

    methods = parse_methods(args.methods) if args.methods else list(METHODS)
    _check_sweep_numbers(args)
    _check_motion_numbers(args)
    if args.vehicles < 1:
        raise UsageError(f"--vehicles = {args.vehicles}: must be ≥ 1")
    fleet = args.vehicles > 1  # studies.fleet_sweep
    more = {"vehicles": args.vehicles} if fleet else {}
    config = (FleetSweepConfig if fleet else SweepConfig)(
        **more,
        n=args.n,
        seed=args.seed,
        methods=methods,
        densities=list(dict.fromkeys(args.density)),
        sensor=args.sensor,
        out=args.out,
        moving=args.moving,
        obstacle_speed=args.obstacle_speed,
    )
    texts = overrides(args)
    faults = None
    if args.faults is not None:
        try:
            faults = faults_from_yaml(args.faults)
        except ValueError as e:
            raise UsageError(f"--faults = {args.faults!r}: {e}") from None
    config.variant = variant_name(
        texts, faults, motion_variant(args.moving, args.obstacle_speed)
    )
    if fleet:
        config.variant = fleet_variant(args.vehicles, config.variant)
    modify = partial(layered, overrides=texts, faults=faults)
    try:
        with dask_client(args.workers, args.scheduler) as client:
            run = run_sweep(config, client, modify, tasks=FLEET if fleet else None)
    except KeyboardInterrupt:
        print(
            f"mfi-drake: interrupted; finished flights are in {args.out}/results.jsonl,"
            " rerun the same command to fly the rest",
            file=sys.stderr,
        )
        return 130
    except OSError as e:  # no scheduler at that address
        raise UsageError(f"--scheduler = {args.scheduler!r}: {e}") from None
    if not fleet:
        plot_sweep(run.summary, os.path.join(args.out, "sweep.png"))
    if args.json:
        print(json.dumps(_json_safe(run.summary)))
    else:
        print((fleet_table if fleet else summary_table)(run.summary))
        print(
            f"flew {run.ran}, found {run.skipped} done; wrote {args.out}/: "
            f"results.jsonl, summary.json, table.md, {'' if fleet else 'sweep.png, '}"
            "failures/"
        )
    for line in run.lost:
        print(f"mfi-drake: not run (rerun to retry): {line}", file=sys.stderr)
    return 1 if run.lost else 0


def _check_sweep_numbers(args) -> None:
    for name, value, least in (("--n", args.n, 1), ("--workers", args.workers, 1)):
        if value < least:
            raise UsageError(f"{name} = {value}: must be ≥ {least}")
    if args.seed < 0:
        raise UsageError(f"--seed = {args.seed}: must be ≥ 0")
    for d in args.density:
        if not (math.isfinite(d) and d >= 0.0):
            raise UsageError(f"--density = {d}: must be a finite number ≥ 0")


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
    _check_motion_numbers(args)
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
    with dask_client(args.workers, args.scheduler) as client:
        try:
            tune(config, client)
        except TuneError as e:
            raise UsageError(str(e)) from None
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
        run = run_sweep(held_out, client, partial(with_overrides, overrides=[tuned]))
    plot_sweep(run.summary, os.path.join(held_out.out, "sweep.png"))
    print(summary_table(run.summary))
    print(f"wrote {held_out.out}/ (held-out fields, seed {args.held_out_seed})")
    return 1 if run.lost else 0


def cmd_analyze(args) -> int:
    from mfi_drake.app.analysis_figures import write_analysis_figures
    from mfi_drake.files import write_json
    from mfi_drake.studies.analysis import run_analysis, summary

    scenario = scenario_of(args)
    out = args.out or os.path.join("out", scenario.name, "analysis")
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


def add_motion(parser: argparse.ArgumentParser, what: str) -> None:
    """--moving and --obstacle-speed (`generator.set_in_motion`)."""
    parser.add_argument(
        "--moving",
        type=float,
        default=0.0,
        metavar="SHARE",
        help=f"{what}, circling at --obstacle-speed (default 0: none; docs/dynamic.md)",
    )
    parser.add_argument(
        "--obstacle-speed",
        type=float,
        default=0.0,
        metavar="M/S",
        help="speed of the moving obstacles",
    )


def add_overrides(parser: argparse.ArgumentParser) -> None:
    """--set and --override, layered on the scenario in the order given."""
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        type=lambda text: ("set", text),
        metavar="YAML",
        help="scenario fields layered on top, e.g. 'faults: {sensor_noise_std: 0.05}'",
    )
    parser.add_argument(
        "--override",
        dest="overrides",
        action="append",
        type=lambda path: ("file", path),
        metavar="FILE",
        help="a YAML file of scenario fields layered on top (e.g. from tune)",
    )


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mfi-drake",
        description="Magnetic-field-inspired quadcopter navigation on Drake.",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="fly a scenario and write its log and figure")
    run.add_argument("scenario", help="scenario YAML file")
    add_overrides(run)
    run.add_argument(
        "--method",
        default="mfi",
        help=f"one of {', '.join(METHODS)}, or MODULE:NAME of your own field "
        "function (default mfi)",
    )
    run.add_argument("--out", help="output directory (default out/<scenario name>)")
    run.add_argument("--json", action="store_true", help="print one JSON object")
    run.add_argument("--html", help="also write a Meshcat animation to this .html")
    run.set_defaults(func=cmd_run)

    comp = sub.add_parser("compare", help="fly a scenario with several methods")
    comp.add_argument("scenario", help="scenario YAML file")
    add_overrides(comp)
    comp.add_argument(
        "--methods",
        default=",".join(METHODS),
        help=f"comma-separated names or MODULE:NAME (default {','.join(METHODS)})",
    )
    comp.add_argument("--out", help="output directory (default out/<scenario name>)")
    comp.add_argument("--json", action="store_true", help="print one JSON object")
    comp.add_argument("--html", help="also write a Meshcat animation to this .html")
    comp.set_defaults(func=cmd_compare)

    rep = sub.add_parser(
        "reproduce", help="the paper's §VI-A comparison: figures and results.md"
    )
    rep.add_argument(
        "--scenarios", default="scenarios", help="directory of the paper's scenarios"
    )
    rep.add_argument("--out", default="out/reproduce", help="output directory")
    add_overrides(rep)
    rep.set_defaults(func=cmd_reproduce)

    sweep = sub.add_parser(
        "sweep", help="Monte Carlo benchmark on random obstacle fields (Dask)"
    )
    add_overrides(sweep)
    sweep.add_argument("--n", type=int, default=30, help="fields per density")
    sweep.add_argument("--seed", type=int, default=0, help="seed of the fields")
    sweep.add_argument(
        "--methods",
        help="comma-separated names or MODULE:NAME, e.g. mfi,apf,gf "
        "(default: every method of the registry)",
    )
    from mfi_drake.world.generator import DEFAULT_DENSITY

    sweep.add_argument(
        "--density",
        type=float,
        nargs="+",
        default=[DEFAULT_DENSITY],
        help="obstacles per m³ of the 8×5×5 m box around the start–goal line "
        f"(default {DEFAULT_DENSITY:g}); several values sweep them all",
    )
    sweep.add_argument("--sensor", choices=["sphere", "depth"], default="sphere")
    sweep.add_argument(
        "--vehicles",
        type=int,
        default=1,
        help="vehicles per field, between random start and goal pairs at the "
        "ends of the box, half each way (default 1: the single-vehicle sweep)",
    )
    add_motion(sweep, "share of each field's obstacles that move")
    sweep.add_argument(
        "--workers",
        type=int,
        default=os.cpu_count() or 1,
        help="local worker processes (default: one per core)",
    )
    sweep.add_argument(
        "--scheduler", help="address of a running Dask scheduler (tcp://host:8786)"
    )
    sweep.add_argument(
        "--faults",
        help="a scenario `faults:` block flown on every field, as YAML, e.g. "
        "'{sensor_noise_std: 0.05, dropout_prob: 0.1}' (each field's seed is "
        "offset by its name); results are keyed by it, so several can share --out",
    )
    sweep.add_argument("--out", default="out/sweep", help="output directory")
    sweep.add_argument("--json", action="store_true", help="print one JSON object")
    sweep.set_defaults(func=cmd_sweep)

    diagram = sub.add_parser("diagram", help="draw the built diagram as SVG (Graphviz)")
    diagram.add_argument("scenario", help="scenario YAML file")
    add_overrides(diagram)
    diagram.add_argument(
        "--method", default="mfi", help="method name or MODULE:NAME (default mfi)"
    )
    diagram.add_argument("--out", required=True, help="output .svg file")
    diagram.set_defaults(func=cmd_diagram)

    tune = sub.add_parser(
        "tune",
        help="one tuning protocol for every method, then held-out fields (Dask)",
    )
    tune.add_argument(
        "--methods",
        default=",".join(METHODS),
        help="comma-separated names or MODULE:NAME (default: every method)",
    )
    tune.add_argument(
        "--candidates", type=int, default=24, help="gain sets per method (budget)"
    )
    tune.add_argument("--seed", type=int, default=100, help="training fields' seed")
    tune.add_argument("--n", type=int, default=10, help="training fields per density")
    tune.add_argument("--density", type=float, nargs="+", default=[0.1, 0.2])
    tune.add_argument(
        "--paper-scenarios", help="a directory whose paper scenarios join training"
    )
    tune.add_argument(
        "--walls", type=int, default=0, help="wall fields that join training"
    )
    add_motion(tune, "each random training field also flown with this share moving")
    tune.add_argument(
        "--jitter",
        type=int,
        default=1,
        help="fly each random training field this many times, started 1 mm apart",
    )
    tune.add_argument(
        "--held-out-seed", type=int, help="seed of the held-out fields (≠ --seed)"
    )
    tune.add_argument("--held-out-n", type=int, default=200)
    tune.add_argument(
        "--held-out-density", type=float, nargs="+", default=[0.05, 0.1, 0.2]
    )
    tune.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    tune.add_argument("--scheduler", help="address of a running Dask scheduler")
    tune.add_argument("--out", default="out/tune", help="output directory")
    tune.set_defaults(func=cmd_tune)

    analyze = sub.add_parser(
        "analyze", help="linearisation, stability and region of attraction (MFI)"
    )
    analyze.add_argument("scenario", help="scenario YAML file")
    add_overrides(analyze)
    analyze.add_argument("--out", help="output directory (default out/<name>/analysis)")
    analyze.add_argument("--json", action="store_true", help="print one JSON object")
    analyze.set_defaults(func=cmd_analyze)
    return parser


def _check_html(args) -> None:
    html = getattr(args, "html", None)
    if html is not None and not html.endswith(".html"):
        raise UsageError(f"--html = {html!r}: must name a .html file")


def main(argv: list[str] | None = None) -> int:
    args = make_parser().parse_args(argv)
    try:
        _check_html(args)
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


if __name__ == "__main__":
    sys.exit(main())
