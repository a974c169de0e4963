"""The registry of methods and a user's own navigation field, flown by name
(MODULE:NAME) from run, compare and sweep and as a callable from Python;
layered scenarios (--set, --override); the memo invariants of the systems."""

import dataclasses
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from pydrake.geometry import Role

from mfi_drake import load_scenario, simulate
from mfi_drake.app.cli import main
from mfi_drake.config.scenario import Obstacle, Scenario, Sphere
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.methods import (
    ALIASES,
    DEFAULT_METHODS,
    METHOD_NAMES,
    METHODS,
    MethodError,
    appearance,
    resolve_method,
)
from mfi_drake.flight.simulator import fly
from mfi_drake.maths.baselines import apf_obstacle_field, attraction_field
from mfi_drake.systems.user_field import UserFieldError

from .conftest import SCENARIOS

PLANAR_WALL = os.path.join(SCENARIOS, "planar_wall.yaml")

# A user's module, as a researcher would write it next to their scenarios.
USER_MODULE = textwrap.dedent(
    """
    import numpy as np

    CONSTANT = 3.0

    def field(position, velocity, obstacle_points, goal):
        # Toward the goal at about 1 m/s, pushed away from what is seen.
        pull = 1.5 * (goal - position) - 2.0 * velocity
        pull *= min(1.0, 3.0 / max(np.linalg.norm(pull), 1e-9))
        push = sum((-p / np.linalg.norm(p) ** 3 for p in obstacle_points), np.zeros(3))
        return pull + 0.3 * push

    def raises_after_one_metre(position, velocity, obstacle_points, goal):
        if position[0] > 1.0:
            raise ValueError("too far\\nfor me")
        return field(position, velocity, obstacle_points, goal)

    def nan_after_one_metre(position, velocity, obstacle_points, goal):
        if position[0] > 1.0:
            return np.array([np.nan, 0.0, 0.0])
        return field(position, velocity, obstacle_points, goal)

    def two_numbers(position, velocity, obstacle_points, goal):
        return np.zeros(2)

    def two_arguments(position, velocity):
        return -velocity

    def undeclared_gain(position, velocity, obstacle_points, goal, k=1.0):
        return k * (goal - position)

    undeclared_gain.gains = {"k": (0.5, 2.0), "q": (0.5, 2.0)}

    def required_gain(position, velocity, obstacle_points, goal, *, k):
        return k * (goal - position) - 2.0 * velocity
    """
)


@pytest.fixture
def user_dir(module_dir):
    """The current directory holds my_nav.py."""
    (module_dir / "my_nav.py").write_text(USER_MODULE)
    return module_dir


def _short(scenario: Scenario, duration: float) -> Scenario:
    return dataclasses.replace(scenario, duration=duration)


def test_registry_names_label_and_colour_every_method():
    assert list(METHODS) == [*("mfi", "mfi-paper", "apf", "gf"), "mfi-memoryless"]
    # The paper's comparison and the published tables fly these unless told.
    assert DEFAULT_METHODS == ("mfi", "mfi-paper", "apf", "gf")
    for name, method in METHODS.items():
        assert method.name == name and method.label and method.colour
        assert resolve_method(name) is method
    # An alias is its method under the name it was asked for (a record of
    # "mfi-nc" keeps its name), and every name is listed once.
    assert ALIASES == {"mfi-nc": "mfi"}
    assert METHOD_NAMES == (*METHODS, "mfi-nc")
    alias = resolve_method("mfi-nc")
    assert alias.name == "mfi-nc"
    assert dataclasses.replace(alias, name="mfi") == METHODS["mfi"]
    assert appearance("mfi-nc") == appearance("mfi")


def test_a_user_field_equal_to_apf_flies_the_apf_flight_exactly():
    # Second method as oracle: APF written as a user field (the same sums in
    # the same order) must give the registry's APF flight to the last bit.
    scenario = _short(load_scenario(PLANAR_WALL), 8.0)
    apf = scenario.apf
    radius = VEHICLES[scenario.vehicle].collision_radius

    def apf_as_user_field(position, velocity, obstacle_points, goal):
        A = B = np.zeros(3)
        for r_o in obstacle_points:
            A_i, B_i = apf_obstacle_field(
                velocity, r_o, 1.0, goal - position, radius, apf
            )
            A, B = A + A_i, B + B_i
        return A + B + attraction_field(position, velocity, goal, apf.attraction)

    mine = simulate(scenario, apf_as_user_field)
    reference = simulate(scenario, "apf")
    assert mine.metrics["method"].endswith(":" + apf_as_user_field.__qualname__)
    assert mine.metrics["steps"] == reference.metrics["steps"]
    np.testing.assert_array_equal(mine.positions, reference.positions)
    # Its F_n is logged where the navigator's terms go.
    np.testing.assert_array_equal(
        mine.log["navigation_force"], mine.log["obstacle_force_terms"][:, :3]
    )


def test_run_flies_a_user_field_by_module_name(user_dir, capsys):
    out = user_dir / "out"
    args = ["run", PLANAR_WALL, "--method", "my_nav:field", "--out", str(out)]
    # A naive field: it reaches the goal through the wall, a collision, so
    # exit status 1, with every output written all the same.
    assert main([*args, "--json"]) == 1
    metrics = json.loads(capsys.readouterr().out)
    assert metrics["method"] == "my_nav:field"
    assert metrics["reached"] and metrics["path_length"] >= 8.0
    assert metrics["outcome"] == "collision"
    assert (out / "trajectory.png").stat().st_size > 10_000


def test_compare_draws_and_tabulates_a_user_field_with_its_label(user_dir, capsys):
    out = user_dir / "out"
    args = ["compare", PLANAR_WALL, "--methods", "mfi,my_nav:field"]
    # In 3 s neither reaches the goal: exit status 1.
    assert main([*args, "--out", str(out), "--set", "duration: 3.0"]) == 1
    table = capsys.readouterr().out
    assert "| planar_wall | field |" in table and "| planar_wall | MFI |" in table
    assert (out / "compare.png").stat().st_size > 10_000


def test_sweep_workers_import_the_user_field(user_dir):
    # A fresh process (like a user's shell) with one worker process of its own.
    out = user_dir / "sweep"
    command = [sys.executable, "-m", "mfi_drake.app.cli", "sweep", "--n", "1"]
    command += ["--workers", "1", "--methods", "my_nav:field,mfi", "--out", str(out)]
    command += ["--set", "duration: 2.0", "--json"]
    env = os.environ | {"PYTHONPATH": ""}
    result = subprocess.run(command, capture_output=True, text=True, env=env)
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads(result.stdout)
    assert set(summary["methods"]) == {"my_nav:field", "mfi"}
    records = [
        json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()
    ]
    assert all(r["engine"] == "systems" for r in records)  # a user's field
    assert {r["outcome"] for r in records} <= {"success", "collision", "timeout"}
    assert all(r["sim_time"] == pytest.approx(2.0) for r in records)
    assert all(r["variant"] == "duration: 2.0" for r in records)
    assert "| my_nav:field |" in (out / "table.md").read_text()


@pytest.mark.parametrize(
    "spec, says",
    [
        ("nosuchmodule:field", "cannot import 'nosuchmodule'"),
        ("my_nav:nothing", "has no 'nothing'"),
        ("my_nav:CONSTANT", "is not callable"),
        ("my_nav", "must be one of"),
        ("bad_module:field", "cannot import 'bad_module' (ZeroDivisionError"),
        ("my_nav:two_arguments", "cannot be called as field(position, velocity,"),
        ("my_nav:undeclared_gain", "and its gains ['k', 'q']: got an unexpected"),
    ],
)
def test_a_bad_spec_is_one_line_exit_2_and_nothing_written(
    user_dir, capsys, spec, says
):
    (user_dir / "bad_module.py").write_text("x = 1 / 0\n")
    out = user_dir / "out"
    for args in (
        ["run", PLANAR_WALL, "--method", spec],
        ["compare", PLANAR_WALL, "--methods", f"mfi,{spec}"],
        ["sweep", "--n", "1", "--methods", spec],
    ):
        assert main([*args, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and repr(spec) in err and says in err, err
        assert not out.exists()


@pytest.mark.parametrize(
    "name, says",
    [
        ("raises_after_one_metre", "raised ValueError: too far for me"),
        ("nan_after_one_metre", "returned [nan, 0.0, 0.0]: must be 3 finite"),
        ("two_numbers", "returned [0.0, 0.0]: must be 3 finite"),
    ],
)
def test_a_failing_user_field_is_one_line_naming_it_and_the_time(
    user_dir, capsys, name, says
):
    out = user_dir / "out"
    assert main(["run", PLANAR_WALL, "--method", f"my_nav:{name}", "--out", str(out)])
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"my_nav:{name} at t = " in err and says in err
    assert "Traceback" not in err
    if name != "two_numbers":  # fails at x = 1 m, not at once
        assert float(err.split("t = ")[1].split(" s")[0]) > 0.5
    with pytest.raises(UserFieldError):
        simulate(load_scenario(PLANAR_WALL), f"my_nav:{name}")


def test_a_gain_the_scenario_supplies_may_be_required(user_dir):
    scenario = load_scenario(
        PLANAR_WALL, [("--set", "{field_gains: {k: 1.0}, duration: 0.5}")]
    )
    flight = simulate(scenario, "my_nav:required_gain")
    assert flight.metrics["sim_time"] == pytest.approx(0.5)
    with pytest.raises(UserFieldError, match="required_gain"):  # not supplied
        simulate(load_scenario(PLANAR_WALL), "my_nav:required_gain")


def test_python_api_rejects_what_is_not_a_method():
    with pytest.raises(MethodError, match="not a method"):
        simulate(Scenario(), 42)


# --- layered scenarios ------------------------------------------------------------
def test_set_and_override_layer_on_the_file_in_order(tmp_path, capsys):
    tuned = tmp_path / "tuned.yaml"
    tuned.write_text("navigator: {c: 5.0}\nduration: 2.0\n")
    args = ["run", PLANAR_WALL, "--out", str(tmp_path / "o"), "--json"]
    args += ["--override", str(tuned), "--set", "duration: 1.0"]
    assert main(args) == 1  # 1 s is a time-out
    metrics = json.loads(capsys.readouterr().out)
    assert metrics["sim_time"] == pytest.approx(1.0)
    base = load_scenario(PLANAR_WALL)
    layered = load_scenario(PLANAR_WALL, [("t", tuned.read_text())])
    # Fields not named keep the file's values, nested ones included.
    assert layered.navigator.c == 5.0 and layered.duration == 2.0
    assert layered.navigator.K_omega == base.navigator.K_omega
    assert layered.obstacles == base.obstacles and layered.goal == base.goal


@pytest.mark.parametrize(
    "args, says",
    [
        (["--set", "navigator: {c: -1.0}"], "navigator.c = -1.0"),
        (["--set", "nosuchfield: 1"], "nosuchfield"),
        (["--set", "faults: {dropout_prob: 2.0}"], "faults.dropout_prob = 2.0"),
        (["--set", "[unclosed"], "not valid YAML"),
        (["--override", "no/such/file.yaml"], "no/such/file.yaml: no such"),
    ],
)
def test_a_bad_override_is_one_line_exit_2(tmp_path, capsys, args, says):
    out = tmp_path / "out"
    assert main(["run", PLANAR_WALL, "--out", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and says in err, err
    assert not out.exists()


# --- memo invariants ----------------------------------------------------------------
def test_changing_parameters_after_the_build_changes_no_flight():
    scenario = _short(load_scenario(PLANAR_WALL), 6.0)
    before = fly(build_diagram(scenario))
    built = build_diagram(scenario)
    # Mutate every parameter object the systems were built from.
    scenario.navigator.c *= 10.0
    scenario.navigator.K_omega *= 10.0
    scenario.navigator.max_tilt = 0.1
    scenario.goal[0] = -20.0
    after = fly(built)
    np.testing.assert_array_equal(after.positions, before.positions)


def test_the_sphere_sensor_reads_geometry_changed_in_its_context():
    scenario = Scenario(
        start=[0.0, 0.0, 1.0],
        goal=[5.0, 0.0, 1.0],
        obstacles=[Obstacle(shape=Sphere(radius=0.5), position=[1.5, 0.0, 1.0])],
    )
    flight = build_diagram(scenario)
    context = flight.diagram.CreateDefaultContext()
    plant_context = flight.plant.GetMyMutableContextFromRoot(context)
    plant_context.SetContinuousState(np.r_[scenario.start, np.zeros(9)])
    port = flight.sensor.GetOutputPort("obstacle")
    sensor_context = flight.sensor.GetMyContextFromRoot(context)
    seen = port.Eval(sensor_context).copy()
    np.testing.assert_allclose(seen[:4], [1.0, 0.0, 0.0, 1.0], atol=1e-12)
    # Remove the obstacle from this context's SceneGraph: same position, new
    # geometry version, so the reading must be computed afresh.
    sg_context = flight.scene_graph.GetMyMutableContextFromRoot(context)
    inspector = flight.scene_graph.model_inspector()
    (geometry,) = inspector.GetAllGeometryIds(Role.kProximity)
    source = inspector.GetOwningSourceName(geometry)
    source_id = next(
        s for s in inspector.GetAllSourceIds() if inspector.GetName(s) == source
    )
    flight.scene_graph.RemoveGeometry(sg_context, source_id, geometry)
    np.testing.assert_array_equal(port.Eval(sensor_context), np.zeros(12))
