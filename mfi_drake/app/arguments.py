"""The command line's shared pieces: `UsageError` (a bad argument, exit
status 2), the help formatter and each command's epilog of exit statuses,
the options several commands share (--set/--override, --out/--json/--html,
the random fields, --n, the workers) and the checks of their values."""

import argparse
import math
import os
import textwrap

from mfi_drake.config.scenario_yaml import read_override
from mfi_drake.flight.methods import METHOD_NAMES, MethodError, resolve_method
from mfi_drake.world.validation import least_goal_gap, load_scenario

EXIT_BAD_INPUT = 2

EXIT_FLIGHT_FAILED = 1


class UsageError(ValueError):
    """A bad command-line argument; reported as one line, exit status 2."""


def json_safe(obj):
    """Metrics with non-finite floats replaced by None (JSON has no inf)."""
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [json_safe(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


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


def default_out(out: str | None, *names: str) -> str:
    """--out, or out/NAMES... where it was not given, checked (`writable`)
    before anything flies."""
    if out is None:
        out = os.path.join("out", *names)
        writable("--out", out, directory=True)
    return out


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


def parse_methods(text: str) -> list[str]:
    """The comma-separated --methods value: distinct names of the registry or
    MODULE:NAME specs, each importable (raises MethodError otherwise)."""
    methods = [m.strip() for m in text.split(",")]
    if not all(methods) or len(set(methods)) < len(methods):
        raise UsageError(
            f"--methods = {text!r}: must be distinct names from {sorted(METHOD_NAMES)} "
            "or MODULE:NAME, separated by commas"
        )
    for method in methods:
        try:
            resolve_method(method)
        except MethodError as e:
            raise UsageError(f"--methods = {text!r}: {e}") from None
    return methods


def at_least(name: str, value: int | None, least: int) -> None:
    if value is not None and value < least:
        raise UsageError(f"{name} = {value}: must be ≥ {least}")


def check_densities(name: str, values: list[float]) -> None:
    for d in values:
        if not (math.isfinite(d) and d >= 0.0):
            raise UsageError(f"{name} = {d}: must be a finite number ≥ 0")


def check_sweep_numbers(args) -> None:
    at_least("--n", args.n, 1)
    at_least("--workers", args.workers, 1)


def check_field_numbers(args) -> None:
    at_least("--seed", args.seed, 0)
    several = isinstance(args.density, list)  # sweep's list, scene's one
    check_densities("--density", args.density if several else [args.density])
    gap = getattr(args, "goal_clearance", None)
    if gap is not None and not (math.isfinite(gap) and gap >= least_goal_gap()):
        raise UsageError(
            f"--goal-clearance = {gap}: must be a number ≥ {least_goal_gap():.3f} m "
            "(the collision radius plus the goal margin, docs/goals.md)"
        )


def check_held_out_numbers(args) -> None:
    at_least("--held-out-seed", args.held_out_seed, 0)
    at_least("--held-out-n", args.held_out_n, 1)
    check_densities("--held-out-density", args.held_out_density)


def check_motion_numbers(args) -> None:
    if not (math.isfinite(args.moving) and 0.0 <= args.moving <= 1.0):
        raise UsageError(f"--moving = {args.moving}: must be a share in [0, 1]")
    speed = args.obstacle_speed
    if not (math.isfinite(speed) and speed >= 0.0) or (args.moving > 0 and speed == 0):
        raise UsageError(
            f"--obstacle-speed = {speed}: must be a finite number > 0 with --moving"
        )


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
        # The sweep's: absent is not the default value given, which a
        # --world other than random refuses (`check_world`).
        default=None if several else DEFAULT_DENSITY,
        help=f"{box}, each ≥ 0; several values sweep them all (default: "
        f"{DEFAULT_DENSITY:g}; random fields only)"
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


def add_field_count(
    parser: argparse.ArgumentParser, n: int, what: str, per: str = "density"
) -> None:
    """--n, checked by `check_sweep_numbers`."""
    parser.add_argument("--n", type=int, default=n, help=f"{what} per {per}, ≥ 1")


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
