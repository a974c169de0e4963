"""Scenario loading: the contract's fields, overrides, and every class of bad
input rejected with one line naming the file, field and value."""

import os
import subprocess
import sys

import pytest

from mfi_drake.app.cli import main
from mfi_drake.config.scenario import ScenarioError
from mfi_drake.world.obstacles import obstacle_distances
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

GOOD = """\
name: test
start: [0.0, 0.0, 1.5]
goal: [6.0, 0.0, 1.5]
duration: 20.0
vehicle: drake_default
sensor: !SphereSensor {radius: 2.5}
obstacles:
  - shape: !Sphere {radius: 0.5}
    position: [3.0, 0.0, 1.5]
    rpy_deg: [0.0, 0.0, 0.0]
navigator: {K_P: 2.0}
simulator: {accuracy: 0.001}
"""


def test_shipped_scenarios_load():
    names = sorted(f for f in os.listdir(SCENARIOS) if f.endswith(".yaml"))
    assert {
        "planar_wall.yaml",
        "three_spheres.yaml",
        "tree.yaml",
        "sharp_corner.yaml",
    } <= set(names)
    for name in names:
        scenario = load_scenario(os.path.join(SCENARIOS, name))
        assert scenario.name == name[:-5]


def test_an_inline_convex_is_the_hull_of_its_vertices(write_yaml):
    """A 1 × 0.8 × 0.6 m box given by its corners and an inner point (which
    the hull drops), scaled by 2: exact distances from points off its faces
    are the closed form."""
    corners = [
        [x, y, z] for x in (-0.25, 0.25) for y in (-0.2, 0.2) for z in (-0.15, 0.15)
    ]
    vertices = str([*corners, [0.0, 0.05, 0.0]])
    text = GOOD.replace(
        "!Sphere {radius: 0.5}", f"!Convex {{vertices: {vertices}, scale: 2}}"
    )
    scenario = load_scenario(write_yaml(text))
    (obstacle,) = scenario.obstacles
    assert obstacle.shape.vertices[-1] == [0.0, 0.05, 0.0] and not obstacle.shape.file
    points = [[3.0, 0.0, 2.5], [3.0, -1.0, 1.5], [4.0, 0.0, 1.5], [3.0, 0.0, 1.5]]
    distances = obstacle_distances(scenario, points)
    assert distances == pytest.approx([0.7, 0.6, 0.5, -0.3], abs=1e-9)


def test_overrides_replace_only_the_named_fields(write_yaml):
    scenario = load_scenario(write_yaml(GOOD))
    assert scenario.navigator.K_P == 2.0
    assert scenario.navigator.K_D == 2.0  # default kept
    assert scenario.simulator.accuracy == 0.001
    assert scenario.simulator.integration_scheme == "runge_kutta3"
    assert scenario.sensor.radius == 2.5


BAD = [
    ("unknown field", GOOD.replace("duration:", "durations:"), "durations"),
    ("short vector", GOOD.replace("[6.0, 0.0, 1.5]", "[6.0, 0.0]"), "goal"),
    ("NaN", GOOD.replace("[6.0, 0.0, 1.5]", "[6.0, .nan, 1.5]"), "goal"),
    ("zero radius", GOOD.replace("{radius: 0.5}", "{radius: 0.0}"), "shape.radius"),
    (
        "negative size",
        GOOD.replace("!Sphere {radius: 0.5}", "!Box {size: [1, -1, 1]}"),
        "shape.size",
    ),
    ("unknown vehicle", GOOD.replace("drake_default", "zeppelin"), "zeppelin"),
    (
        "unknown shape",
        GOOD.replace("!Sphere {radius: 0.5}", "!Cone {radius: 0.5}"),
        "Cone",
    ),
    ("negative gain", GOOD.replace("{K_P: 2.0}", "{K_P: -2.0}"), "navigator.K_P"),
    ("r_b beyond r_l", GOOD.replace("{K_P: 2.0}", "{r_b: 2.0}"), "navigator.r_b"),
    (
        "negative margin",
        GOOD.replace("{K_P: 2.0}", "{brake_margin: -0.1}"),
        "navigator.brake_margin = -0.1: must be ≥ 0",
    ),
    (
        "whole margin",
        GOOD.replace("{K_P: 2.0}", "{brake_margin: 1.0}"),
        "navigator.brake_margin = 1.0: must be < 1",
    ),
    (
        "start inside",
        GOOD.replace("[0.0, 0.0, 1.5]\ngoal", "[3.0, 0.1, 1.5]\ngoal"),
        "start",
    ),
    ("goal too close", GOOD.replace("[6.0, 0.0, 1.5]", "[3.7, 0.0, 1.5]"), "goal"),
    ("zero duration", GOOD.replace("duration: 20.0", "duration: 0"), "duration"),
    ("sensor radius", GOOD.replace("{radius: 2.5}", "{radius: -1}"), "sensor.radius"),
    (
        "missing mesh",
        GOOD.replace("!Sphere {radius: 0.5}", "!Convex {file: nope.obj}"),
        "nope.obj",
    ),
    (
        "flat mesh",
        GOOD.replace("!Sphere {radius: 0.5}", "!Convex {file: flat.obj}"),
        "non-coplanar",
    ),
    (
        "flat inline vertices",
        GOOD.replace(
            "!Sphere {radius: 0.5}",
            "!Convex {vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]}",
        ),
        "shape.vertices",
    ),
    (
        "vertex of two numbers",
        GOOD.replace("!Sphere {radius: 0.5}", "!Convex {vertices: [[0, 0]]}"),
        "shape.vertices[0]",
    ),
    (
        "file and vertices",
        GOOD.replace(
            "!Sphere {radius: 0.5}", "!Convex {file: a.obj, vertices: [[0, 0, 0]]}"
        ),
        "one of file and vertices",
    ),
    (
        "neither file nor vertices",
        GOOD.replace("!Sphere {radius: 0.5}", "!Convex {scale: 2}"),
        "one of file and vertices",
    ),
    ("no goal", GOOD.replace("goal: [6.0, 0.0, 1.5]\n", ""), "goal: missing"),
    ("empty goal", GOOD.replace("[6.0, 0.0, 1.5]", "[]"), "goal: missing"),
    ("not yaml", "name: [unclosed\n", "scenario.yaml"),
    ("wrong type", GOOD.replace("duration: 20.0", "duration: soon"), "duration"),
]


@pytest.mark.parametrize("label, text, needle", BAD, ids=[b[0] for b in BAD])
def test_bad_input_is_one_clear_line(write_yaml, tmp_path, label, text, needle):
    (tmp_path / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\n")
    path = write_yaml(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert "\n" not in message
    assert path in message and needle in message


def test_cli_reports_bad_input_with_exit_2_and_no_traceback(write_yaml, capsys):
    path = write_yaml(GOOD.replace("{K_P: 2.0}", "{K_D: .nan}"))
    assert main(["run", path]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("mfi-drake: error:") and "navigator.K_D" in err
    assert len(err.splitlines()) == 1
    assert main(["run", str(path) + ".missing"]) == 2
    assert main(["run", path, "--method", "nope"]) == 2


def test_console_script_exit_status(write_yaml):
    path = write_yaml(GOOD.replace("drake_default", "zeppelin"))
    done = subprocess.run(
        [sys.executable, "-m", "mfi_drake.app.cli", "run", path],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2
    assert "Traceback" not in done.stderr and "zeppelin" in done.stderr


def test_a_scenario_without_goal_is_exit_2_unless_an_override_gives_it(
    write_yaml, tmp_path, capsys
):
    path = write_yaml(GOOD.replace("goal: [6.0, 0.0, 1.5]\n", ""))
    out = tmp_path / "out"
    assert main(["run", path, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{path}: goal: missing" in err
    assert not out.exists()
    assert load_scenario(path, [("--set", "goal: [6, 0, 1.5]")]).goal == [6, 0, 1.5]
