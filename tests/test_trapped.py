"""Outcome "trapped" (docs/nonconvex.md): a goal nothing can reach ends a
flight of the default mfi when its escape rule has run out of options, well
before the time limit; mfi-memoryless, which has no such rule, flies to the
limit."""

import dataclasses
import json

from mfi_drake.app.cli import main
from mfi_drake.flight.result import outcome
from mfi_drake.flight.simulation import simulate
from mfi_drake.studies.sweep import SWEEP_ENDS
from mfi_drake.world.generator import write_scenario

from .test_escape import sealed_box
from .test_nonconvex_worlds import connected


def test_a_sealed_box_ends_trapped_and_run_says_so(tmp_path, capsys):
    box = sealed_box()
    # The oracle: A* finds no way out of the box, so none in.
    assert not connected(box, box.goal, box.start)
    path = tmp_path / "sealed.yaml"
    write_scenario(box, str(path))
    out = str(tmp_path / "out")
    # On the compiled engine (the same flights as the systems engine's,
    # tests/test_escape_compiled.py), in a quarter of the CPU.
    run = ["run", str(path), "--json", "--out", out]  # the default mfi
    run += ["--set", "engine: compiled"]
    assert main(run) == 1  # not a success
    metrics = json.loads(capsys.readouterr().out)
    assert metrics["outcome"] == "trapped" and metrics["trapped"] is True
    assert metrics["sim_time"] < 0.85 * box.duration  # ended by the rule
    assert metrics["min_clearance"] > 0.0 and not metrics["reached"]
    # The same goal without the rule: its flight ends at its limit, a
    # timeout (30 s: MFI dithers in the box).
    limit = dataclasses.replace(box, duration=30.0, engine="compiled")
    mfi = simulate(limit, "mfi-memoryless", **SWEEP_ENDS).metrics
    assert outcome(mfi) == mfi["outcome"] == "timeout" and "trapped" not in mfi
    assert mfi["sim_time"] == limit.duration


def test_outcome_names_a_trapped_vehicle_unless_it_collided_or_all_reached():
    """Hand-made metrics: one vehicle, then a fleet of two."""
    one = {"reached": False, "collided": False}
    assert outcome(one) == "timeout"
    assert outcome(one | {"trapped": True}) == "trapped"
    assert outcome(one | {"trapped": True, "collided": True}) == "collision"
    ok = {"reached": True, "collided": False}
    fleet = {"vehicles": [ok, one | {"trapped": True}], "min_separation": 1.0}
    assert outcome(fleet) == "trapped"
    assert outcome(fleet | {"min_separation": 0.0}) == "collision"
    assert outcome({"vehicles": [ok, one], "min_separation": 1.0}) == "timeout"
    assert outcome({"vehicles": [ok, ok], "min_separation": 1.0}) == "success"
