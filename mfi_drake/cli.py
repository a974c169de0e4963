"""The `mfi-drake` command line.

Every command validates its input before anything is simulated; a bad
scenario or argument is reported as one line on stderr with exit status 2.
"""

import argparse
import json
import math
import os
import subprocess
import sys

from mfi_drake.scenario import ScenarioError, load_scenario

EXIT_BAD_INPUT = 2


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
    outcome = (
        "SUCCESS"
        if metrics["success"]
        else ("COLLISION" if metrics["collided"] else "NOT REACHED")
    )
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


def cmd_run(args) -> int:
    from mfi_drake.outputs import write_flight_log
    from mfi_drake.plotting import plot_flights
    from mfi_drake.simulation import simulate

    scenario = load_scenario(args.scenario)
    out = args.out or os.path.join("out", scenario.name)
    flight = simulate(scenario, args.method)
    write_flight_log(os.path.join(out, "trajectory.npz"), flight)
    plot_flights(scenario, [flight], os.path.join(out, "trajectory.png"))
    if args.json:
        print(json.dumps(_json_safe(flight.metrics)))
    else:
        print(summary_line(flight.metrics))
        print(f"wrote {out}/trajectory.npz and {out}/trajectory.png")
    return 0


def cmd_diagram(args) -> int:

    from mfi_drake.diagram import build_diagram

    scenario = load_scenario(args.scenario)
    if not args.out.endswith(".svg"):
        raise UsageError(f"--out = {args.out!r}: must name a .svg file")
    flight = build_diagram(scenario, args.method)
    dot = flight.diagram.GetGraphvizString(max_depth=1)
    try:
        svg = subprocess.run(
            ["dot", "-Tsvg"], input=dot.encode(), capture_output=True, check=True
        ).stdout
    except FileNotFoundError:
        raise UsageError(
            "Graphviz `dot` is not installed (apt-get install graphviz)"
        ) from None
    from mfi_drake.outputs import atomic_path

    with atomic_path(args.out) as tmp, open(tmp, "wb") as f:
        f.write(svg)
    print(f"wrote {args.out}")
    return 0


def cmd_analyze(args) -> int:
    from mfi_drake.analysis import run_analysis, summary
    from mfi_drake.outputs import write_json

    scenario = load_scenario(args.scenario)
    out = args.out or os.path.join("out", scenario.name, "analysis")
    report = _json_safe(run_analysis(scenario, out))
    write_json(os.path.join(out, "analysis.json"), report)
    if args.json:
        print(json.dumps(report))
    else:
        print(summary(report))
        print(f"wrote {out}/analysis.json and {', '.join(report['figures'])} figures")
    return 0


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mfi-drake",
        description="Magnetic-field-inspired quadcopter navigation on Drake.",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="fly a scenario and write its log and figure")
    run.add_argument("scenario", help="scenario YAML file")
    run.add_argument("--method", default="mfi", help="navigation method (default mfi)")
    run.add_argument("--out", help="output directory (default out/<scenario name>)")
    run.add_argument("--json", action="store_true", help="print one JSON object")
    run.set_defaults(func=cmd_run)

    diagram = sub.add_parser("diagram", help="draw the built diagram as SVG (Graphviz)")
    diagram.add_argument("scenario", help="scenario YAML file")
    diagram.add_argument(
        "--method", default="mfi", help="navigation method (default mfi)"
    )
    diagram.add_argument("--out", required=True, help="output .svg file")
    diagram.set_defaults(func=cmd_diagram)

    analyze = sub.add_parser(
        "analyze", help="linearisation, stability and region of attraction (MFI)"
    )
    analyze.add_argument("scenario", help="scenario YAML file")
    analyze.add_argument("--out", help="output directory (default out/<name>/analysis)")
    analyze.add_argument("--json", action="store_true", help="print one JSON object")
    analyze.set_defaults(func=cmd_analyze)
    return parser


def _check_method(args) -> None:
    from mfi_drake.diagram import NAVIGATORS

    method = getattr(args, "method", None)
    if method is not None and method not in NAVIGATORS:
        raise UsageError(f"--method = {method!r}: must be one of {sorted(NAVIGATORS)}")


def main(argv: list[str] | None = None) -> int:
    args = make_parser().parse_args(argv)
    try:
        _check_method(args)
        return args.func(args)
    except (ScenarioError, UsageError) as e:
        print(f"mfi-drake: error: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
