"""The diagram command and the command line's argument handling: every
option's help shows its default and the limits it is refused beyond, the
exit statuses, tune's warning without a held-out phase."""

import argparse
import json
import os
import shutil

import pytest

from mfi_drake.app.cli import main, make_parser
from mfi_drake.studies import cluster as study_cluster

from .conftest import SCENARIOS


@pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz `dot` not installed")
def test_diagram_command_draws_every_named_system(tmp_path):
    out = tmp_path / "d.svg"
    assert (
        main(
            ["diagram", os.path.join(SCENARIOS, "planar_wall.yaml"), "--out", str(out)]
        )
        == 0
    )
    svg = out.read_text()
    assert svg.lstrip().startswith("<?xml") and "</svg>" in svg
    for name in [
        "quadrotor",
        "sensor",
        "navigator",
        "selector",
        "attitude_pd",
        "mixer",
    ]:
        assert name in svg


def test_diagram_needs_an_svg_name(tmp_path, capsys):
    path = os.path.join(SCENARIOS, "planar_wall.yaml")
    assert main(["diagram", path, "--out", str(tmp_path / "d.png")]) == 2
    assert "--out" in capsys.readouterr().err


def subcommands() -> dict[str, argparse.ArgumentParser]:
    (action,) = [
        a for a in make_parser()._actions if isinstance(a, argparse._SubParsersAction)
    ]
    return action.choices


def expanded_help(parser: argparse.ArgumentParser, flag: str) -> str:
    """The help line of `flag` as `--help` prints it (default included)."""
    (action,) = [a for a in parser._actions if flag in a.option_strings]
    return parser._get_formatter()._expand_help(action)


def test_every_option_of_every_command_has_help_showing_its_default():
    commands = subcommands()
    assert set(commands) == {
        "run",
        "compare",
        "reproduce",
        "sweep",
        "scene",
        "diagram",
        "tune",
        "analyze",
    }
    for name, parser in commands.items():
        for action in parser._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            where = f"{name} {action.option_strings or action.dest}"
            assert action.help and action.help.strip(), f"{where}: no help"
            if not action.option_strings or action.required:
                continue  # positional or required: no default to show
            text = parser._get_formatter()._expand_help(action)
            if isinstance(action.default, bool):  # a switch: off unless given
                assert action.default is False, where
            elif action.default is None:  # absent: the help says what that means
                assert "(default: " in text, f"{where}: {text}"
            else:
                assert f"(default: {action.default}" in text, f"{where}: {text}"
        epilog = parser.format_help().split("exit status:")[1]
        assert "\n  0  " in epilog and "\n  2  bad input" in epilog, name


# Each refused value and the limit that --help states for it.
LIMITS = [
    ("tune", "--candidates", "2", "≥ 3"),
    ("tune", "--jitter", "8", "to 7"),
    ("tune", "--walls", "-1", "≥ 0"),
    ("tune", "--n", "0", "≥ 1"),
    ("tune", "--seed", "-1", "≥ 0"),
    ("tune", "--held-out-n", "0", "≥ 1"),
    ("tune", "--held-out-seed", "-1", "≥ 0"),
    ("tune", "--held-out-density", "-0.1", "≥ 0"),
    ("tune", "--workers", "0", "≥ 1"),
    ("sweep", "--n", "0", "≥ 1"),
    ("sweep", "--seed", "-1", "≥ 0"),
    ("sweep", "--workers", "0", "≥ 1"),
    ("sweep", "--density", "-1", "≥ 0"),
    ("sweep", "--moving", "1.5", "[0, 1]"),
    ("reproduce", "--workers", "5", "1 to 4"),
]


@pytest.mark.parametrize("command, flag, value, limit", LIMITS)
def test_a_refused_value_breaks_the_limit_its_help_states(
    tmp_path, capsys, command, flag, value, limit
):
    assert limit in expanded_help(subcommands()[command], flag)
    assert main([command, flag, value, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{flag} = {value}" in err and limit in err, err
    assert not any(tmp_path.iterdir())


class NoClusterError(Exception):
    """Raised in place of starting Dask: the command got that far."""


def no_cluster(*args):
    raise NoClusterError


def test_tune_warns_once_when_it_has_no_held_out_phase(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(study_cluster, "dask_client", no_cluster)
    args = ["tune", "--methods", "mfi", "--out", str(tmp_path)]
    for extra, warned in (([], True), (["--held-out-seed", "5"], False)):
        with pytest.raises(NoClusterError):
            main(args + extra)
        err = capsys.readouterr().err
        assert err.count("\n") == warned
        assert ("warning: no --held-out-seed" in err) == warned


PLANAR_WALL = os.path.join(SCENARIOS, "planar_wall.yaml")


@pytest.mark.parametrize(
    "change, outcome",
    [
        ("duration: 0.5", "timeout"),
        # Blind (a 5 cm sensing sphere), MFI flies into the wall.
        ("{sensor: !SphereSensor {radius: 0.05}, duration: 5}", "collision"),
    ],
)
def test_run_exits_1_on_a_failed_flight_and_writes_its_outputs(
    tmp_path, capsys, change, outcome
):
    args = ["run", PLANAR_WALL, "--set", change, "--out", str(tmp_path), "--json"]
    assert main(args) == 1
    assert json.loads(capsys.readouterr().out)["outcome"] == outcome
    assert (tmp_path / "trajectory.png").stat().st_size > 10_000
    assert (tmp_path / "trajectory.npz").stat().st_size > 1_000


@pytest.mark.parametrize(
    "command, flag, target, words",
    [
        ("run", "--out", "a_file", "is a file, not a directory"),
        ("compare", "--out", "a_file/sub", "a_file is not a directory"),
        ("run", "--html", "a_dir.html", "is a directory"),
        ("analyze", "--out", "a_file/x/y", "a_file is not a directory"),
        ("diagram", "--out", "a_dir.svg", "is a directory"),
    ],
)
def test_an_output_that_cannot_be_written_is_refused_before_any_flight(
    tmp_path, capsys, command, flag, target, words
):
    (tmp_path / "a_file").write_text("")
    made = ["a_dir.html", "a_dir.svg", "a_file"]
    for name in made[:2]:
        (tmp_path / name).mkdir()
    args = [command, PLANAR_WALL, flag, str(tmp_path / target)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{flag} = " in err and words in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == made


def test_the_default_output_is_checked_before_any_flight(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out").write_text("")  # a file where out/<name>/ must go
    assert main(["run", PLANAR_WALL]) == 2
    err = capsys.readouterr().err
    assert "--out = 'out/planar_wall'" in err and "is not a directory" in err, err


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_a_bad_value_from_a_layer_names_the_layers(
    tmp_path, capsys, monkeypatch, command
):
    """The file says duration: 40; the error must blame the --set, and the
    sweep must refuse before its cluster starts or its directory exists."""
    monkeypatch.setattr(study_cluster, "dask_client", no_cluster)
    out = tmp_path / "out"
    where = [PLANAR_WALL] if command == "run" else ["--n", "1"]
    args = [command, *where, "--set", "duration: -1", "--out", str(out)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "with --set 'duration: -1': duration = -1.0: must be" in err, err
    assert not out.exists()
