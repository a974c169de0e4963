"""The commands that fly given scenarios: `run`, `compare`, `reproduce`,
`diagram` and `analyze`, each its parser (`add_run`, ...) and what it does
(`cmd_run`, ...): read the arguments, call the flight and study functions,
print and write the results."""

import json
import os
import subprocess
from functools import partial

from mfi_drake.app.arguments import (
    EXIT_FLIGHT_FAILED,
    USER_FIELD_FAILED,
    UsageError,
    add_flight_outputs,
    add_overrides,
    add_parser,
    at_least,
    default_out,
    exit_statuses,
    json_safe,
    overrides,
    parse_methods,
    scenario_of,
)
from mfi_drake.flight.methods import (
    DEFAULT_METHODS,
    METHOD_NAMES,
    METHODS,
    resolve_method,
)


def summary_line(metrics: dict) -> str:
    """One human line with the outcome and the key numbers of a run; for a
    fleet, its outcome and least separation, then the first vehicle's."""
    outcome = {
        "success": "SUCCESS",
        "collision": "COLLISION",
        "timeout": "NOT REACHED",
        "trapped": "TRAPPED (the escape rule ran out of options)",
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


def cmd_run(args) -> int:
    from mfi_drake.app.figures import plot_flights
    from mfi_drake.app.flight_log import write_flight_log
    from mfi_drake.flight.simulation import simulate

    at_least("--processes", args.processes, 1)
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
        print(json.dumps(json_safe(flight.metrics)))
    else:
        print(summary_line(flight.metrics))
        print(f"wrote {out}/trajectory.npz and {out}/trajectory.png")
        if args.html:
            print(f"wrote {args.html}")
    return flights_status([flight])


def flights_status(flights: list) -> int:
    """run's and compare's exit status: 0 when every flight succeeded (reached
    the goal without a collision), else EXIT_FLIGHT_FAILED."""
    return 0 if all(f.metrics["success"] for f in flights) else EXIT_FLIGHT_FAILED


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
        print(json.dumps(json_safe({"scenario": scenario.name, "results": metrics})))
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


def cmd_analyze(args) -> int:
    from mfi_drake.app.analysis_figures import write_analysis_figures
    from mfi_drake.files import write_json
    from mfi_drake.studies.analysis import run_analysis, summary

    scenario = scenario_of(args)
    out = default_out(args.out, scenario.name, "analysis")
    report, series = run_analysis(scenario)
    report["figures"] = write_analysis_figures(series, out)
    report = json_safe(report)
    write_json(os.path.join(out, "analysis.json"), report)
    if args.json:
        print(json.dumps(report))
    else:
        print(summary(report))
        print(f"wrote {out}/analysis.json and {', '.join(report['figures'])} figures")
    return 0


def add_run(sub) -> None:
    """The `run` command's parser, added to the subparsers `sub`."""
    methods = ", ".join(METHOD_NAMES)
    run = add_parser(
        sub,
        "run",
        "fly a scenario and write its log and figure",
        exit_statuses(
            "the flight succeeded: it reached the goal without a collision",
            "the flight collided, timed out or was trapped (the log and figure "
            f"are written all the same), or {USER_FIELD_FAILED}",
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


def add_compare(sub) -> None:
    """The `compare` command's parser, added to the subparsers `sub`."""
    comp = add_parser(
        sub,
        "compare",
        "fly a scenario with several methods",
        exit_statuses(
            "every method's flight succeeded",
            "a method's flight collided, timed out or was trapped (every method "
            f"is flown and written all the same), or {USER_FIELD_FAILED}",
        ),
    )
    comp.add_argument("scenario", help="scenario YAML file")
    add_overrides(comp)
    comp.add_argument(
        "--methods",
        metavar="M,M,...",
        default=",".join(DEFAULT_METHODS),
        help="distinct names or MODULE:NAME, separated by commas",
    )
    add_flight_outputs(comp, "print every method's metrics as one JSON object")
    comp.set_defaults(func=cmd_compare)


def add_reproduce(sub) -> None:
    """The `reproduce` command's parser, added to the subparsers `sub`."""
    from mfi_drake.studies.compare import PAPER_SCENARIOS

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


def add_diagram(sub) -> None:
    """The `diagram` command's parser, added to the subparsers `sub`."""
    methods = ", ".join(METHOD_NAMES)
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


def add_analyze(sub) -> None:
    """The `analyze` command's parser, added to the subparsers `sub`."""
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
