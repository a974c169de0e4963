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
import sys
import warnings
from collections.abc import Callable

from mfi_drake.app.arguments import (
    EXIT_BAD_INPUT,
    EXIT_FLIGHT_FAILED,
    HelpFormatter,
    UsageError,
    writable,
)
from mfi_drake.app.flight_commands import (
    add_analyze,
    add_compare,
    add_diagram,
    add_reproduce,
    add_run,
)
from mfi_drake.app.scene_command import add_scene
from mfi_drake.app.study_commands import add_sweep, add_tune
from mfi_drake.config.scenario import ScenarioError
from mfi_drake.flight.methods import MethodError
from mfi_drake.systems.user_field import UserFieldError
from mfi_drake.world.validation import ScenarioWarning


def make_parser() -> argparse.ArgumentParser:
    """The `mfi-drake` parser: every command, in the order its help lists
    them."""
    parser = argparse.ArgumentParser(
        prog="mfi-drake",
        description="Magnetic-field-inspired quadcopter navigation on Drake.",
        epilog="Each command's --help lists its options with their defaults and "
        f"what its exit statuses mean; {EXIT_BAD_INPUT} is always bad input.",
        formatter_class=HelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True)
    for add in (
        add_run,
        add_compare,
        add_reproduce,
        add_sweep,
        add_scene,
        add_diagram,
        add_tune,
        add_analyze,
    ):
        add(sub)
    return parser


def _check_html(args) -> None:
    html = getattr(args, "html", None)
    if html is not None and not html.endswith(".html"):
        raise UsageError(f"--html = {html!r}: must name a .html file")


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
