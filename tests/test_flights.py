"""End to end: the shipped scenarios, scenarios never seen in tuning, the
run command's contract, and what the log records."""

import json
import os

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from mfi_drake.app.cli import main
from mfi_drake.config.scenario import (
    Box,
    Capsule,
    Cylinder,
    Ellipsoid,
    Obstacle,
    Scenario,
    Sphere,
)
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths import fields
from mfi_drake.systems.navigation import GoalAttractionSelector
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

PAPER = ["planar_wall", "three_spheres", "tree", "sharp_corner"]


@pytest.mark.parametrize("name", PAPER)
def test_paper_scenario_succeeds_without_collision(name):
    flight = simulate(load_scenario(os.path.join(SCENARIOS, f"{name}.yaml")))
    m = flight.metrics
    assert m["success"], m
    assert m["min_clearance"] > 0.05
    assert m["final_error"] < 0.1 and m["convergence_time"] is not None


UNSEEN = {
    # Obstacles straight on the start–goal line, shapes and layouts not tuned on.
    "capsule_on_line": [Obstacle(Capsule(0.5, 2.0), [4.0, 0.0, 1.5], [90.0, 0.0, 0.0])],
    "lying_cylinder": [
        Obstacle(Cylinder(0.6, 5.0), [3.5, 0.0, 1.5], [90.0, 0.0, 10.0])
    ],
    "ellipsoid": [
        Obstacle(Ellipsoid([0.6, 1.5, 1.0]), [4.0, 0.0, 1.5], [0.0, 0.0, 20.0])
    ],
    "tilted_box_pair": [
        Obstacle(Box([0.5, 2.5, 2.0]), [3.0, 0.3, 1.5], [0.0, 0.0, 35.0]),
        Obstacle(Box([0.5, 2.5, 2.0]), [5.5, -0.5, 1.5], [0.0, 20.0, -30.0]),
    ],
    # A wall far wider than the sensing radius: the goal pulls into it for long.
    "wide_wall": [Obstacle(Box([0.2, 12.0, 3.0]), [4.0, 0.0, 1.5])],
    "slit": [
        Obstacle(Box([1.0, 4.0, 3.0]), [4.0, 2.7, 1.5]),
        Obstacle(Box([1.0, 4.0, 3.0]), [4.0, -2.7, 1.5]),
    ],
    "sphere_cluster": [
        Obstacle(Sphere(0.5), [3.0, 0.0, 1.5]),
        Obstacle(Sphere(0.5), [3.0, 1.2, 1.5]),
        Obstacle(Sphere(0.5), [3.0, -1.2, 1.5]),
        Obstacle(Sphere(0.4), [5.0, 0.2, 2.0]),
    ],
}


@pytest.mark.parametrize("name", sorted(UNSEEN))
@pytest.mark.parametrize("vehicle", ["drake_default", "pelican"])
def test_unseen_layouts_are_flown_to_the_goal(name, vehicle):
    scenario = Scenario(
        name=name,
        start=[0.0, 0.0, 1.5],
        goal=[8.0, 0.0, 1.5],
        duration=40.0,
        vehicle=vehicle,
        obstacles=UNSEEN[name],
    )
    m = simulate(scenario).metrics
    assert m["success"], m
    assert m["min_clearance"] > 0.0


def test_log_records_every_step_and_the_mode_switches_at_the_guards():
    scenario = load_scenario(os.path.join(SCENARIOS, "planar_wall.yaml"))
    flight = simulate(scenario)
    t = flight.times
    assert np.all(np.diff(t) > 0) and t[-1] == pytest.approx(scenario.duration)
    assert flight.metrics["steps"] == len(t)
    mode = flight.log["mode"][:, 0]
    switches = np.nonzero(np.diff(mode))[0] + 1
    assert mode[0] == fields.MODE_PD and mode[-1] == fields.MODE_PD
    assert list(mode[switches]) == [fields.MODE_CRUISE, fields.MODE_PD]
    P = scenario.navigator
    x = flight.log["state"]
    # The witness localises each switch: the guard is ~0 at the last sample
    # before it (the update takes effect from the next step on).
    k = switches[0] - 1
    assert np.linalg.norm(x[k, 6:9]) == pytest.approx(P.v_min, abs=0.01)
    k = switches[1] - 1
    goal_distance = np.linalg.norm(x[k, :3] - scenario.goal)
    assert goal_distance == pytest.approx(P.r_gl, abs=0.01)
    # F_n is the sum of its logged parts (eq 21).
    parts = flight.log["obstacle_force_terms"].reshape(-1, 2, 3).sum(axis=1)
    parts += flight.log["goal_force_terms"].reshape(-1, 3, 3).sum(axis=1)
    np.testing.assert_allclose(flight.log["navigation_force"], parts, atol=1e-12)


def test_run_command_writes_log_and_figure_and_prints_the_json(tmp_path, capsys):
    out = tmp_path / "out"
    path = os.path.join(SCENARIOS, "sharp_corner.yaml")
    assert main(["run", path, "--out", str(out), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    keys = ["scenario", "method", "sensor", "reached", "collided", "success"]
    keys += ["min_clearance", "path_length", "final_error", "convergence_time"]
    keys += ["sim_time", "wall_time", "realtime_factor"]
    assert set(keys) <= set(result)
    assert result["method"] == "mfi" and result["sensor"] == "sphere"
    assert result["success"] is True
    log = np.load(out / "trajectory.npz")
    assert log["state"].shape == (len(log["times"]), 12)
    assert json.loads(str(log["metrics"]))["path_length"] == result["path_length"]
    png = (out / "trajectory.png").read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) > 20_000
    assert not [f for f in os.listdir(out) if f.startswith(".tmp")]


def test_eq21_switches_when_the_state_it_reads_jumps_across_a_guard():
    """A sampled state estimate jumps between steps, where no witness can see
    a crossing: the mode follows eq 21 from the next step on all the same
    (it once stayed in PD at 4.9 m/s: the PD pull is saturated, not
    damped, far from the goal)."""
    goal = [10.0, 0.0, 2.0]
    selector = GoalAttractionSelector(Scenario().navigator, goal)
    simulator = Simulator(selector)
    context = simulator.get_mutable_context()
    context.SetAccuracy(1e-2)
    x = np.zeros(12)
    x[:3] = [0.0, 0.0, 2.0]
    state = selector.GetInputPort("state")
    state.FixValue(context, x)
    selector.GetInputPort("obstacle_force").FixValue(context, np.zeros(3))
    simulator.Initialize()
    mode = selector.GetOutputPort("mode")
    assert mode.Eval(context)[0] == fields.MODE_PD  # at rest
    x[6] = 1.0  # the estimate jumps to 1 m/s: eq 21 leaves PD
    state.FixValue(context, x)
    simulator.AdvanceTo(0.1)
    assert mode.Eval(context)[0] == fields.MODE_CRUISE
    x[6] = 0.0  # and back to rest: cruise falls back to PD
    state.FixValue(context, x)
    simulator.AdvanceTo(0.2)
    assert mode.Eval(context)[0] == fields.MODE_PD
