"""`sweep --world`: the generated non-convex worlds flown as a sweep flies
random fields, keyed by class, resumed, and tabulated by class."""

import dataclasses
import json
import sys

import pytest

from mfi_drake.app.cli import main
from mfi_drake.studies import records as record_store
from mfi_drake.studies import sweep
from mfi_drake.world.nonconvex import KINDS, nonconvex_world

from .conftest import load_benchmark


def test_nonconvex_names_n_worlds_of_every_class_and_random_keys_stay_as_they_were():
    config = sweep.SweepConfig(n=3, methods=["mfi-nc"], world=sweep.NONCONVEX)
    keys = config.flight_keys()
    assert len(keys) == 3 * len(KINDS)
    assert {(k.world, k.index) for k in keys} == {
        (kind, i) for kind in KINDS for i in range(3)
    }
    assert {k.density for k in keys} == {None}
    # A random field's record has the keys it had before worlds, and reads
    # back as a random field's key.
    random = sweep.SweepConfig(n=1, methods=["mfi"]).flight_keys()[0]
    record = record_store.key_record(random)
    assert list(record) == ["variant", "sensor", "density", "seed", "index", "method"]
    assert record_store.record_key(record) == random
    world = record_store.key_record(keys[0])
    assert world["world"] == KINDS[0] and record_store.record_key(world) == keys[0]


def _short(scenario):
    """A 1 s flight: cheap, and a timeout (the goal is 10 m away)."""
    return dataclasses.replace(scenario, duration=1.0)


def test_a_world_sweep_flies_resumes_and_tabulates_by_class(tmp_path, threads_client):
    config = sweep.SweepConfig(
        n=2, seed=3, methods=["mfi-nc"], world="window_wall", out=str(tmp_path)
    )
    first = sweep.run_sweep(config, threads_client, _short, sys.stdout)
    assert (first.ran, first.skipped, first.lost) == (2, 0, [])
    results = tmp_path / "results.jsonl"
    records = [json.loads(x) for x in results.read_text().splitlines()]
    # Each record is world `index` of its class, as nonconvex_world draws it.
    for r in records:
        assert (r["world"], r["density"], r["outcome"]) == (
            "window_wall",
            None,
            "timeout",
        )
        assert r["scenario"] == nonconvex_world("window_wall", 3, r["index"]).name
    # Resume: a kill after the first flight flies only the second again.
    results.write_text(results.read_text().splitlines(keepends=True)[0])
    again = sweep.run_sweep(config, threads_client, _short, sys.stdout)
    assert (again.ran, again.skipped) == (1, 1)
    stats = again.summary["methods"]["mfi-nc"]["by_world"]["window_wall"]
    assert stats["n"] == 2 and stats["timeout_rate"] == 1.0
    assert stats["trapped_rate"] == 0.0
    table = (tmp_path / "table.md").read_text()
    assert "| method | world | flights |" in table and "trapped [95% CI]" in table
    assert "| mfi-nc | window_wall | 2 |" in table


@pytest.mark.parametrize(
    "args, named",
    [
        (["--density", "0.1"], "--density = 0.1"),
        (["--vehicles", "2"], "--vehicles = 2"),
        (["--moving", "0.3", "--obstacle-speed", "1"], "--moving = 0.3"),
        (["--goal-clearance", "0.5"], "--goal-clearance = 0.5"),
    ],
)
def test_options_of_random_fields_are_refused_with_a_world(
    tmp_path, capsys, args, named
):
    assert main(["sweep", "--world", "cup", "--out", str(tmp_path), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert named in err
    assert not any(tmp_path.iterdir())


def test_the_comparison_page_tabulates_a_world_sweep_by_class(tmp_path):
    """Hand-made records: each class's world 0 and 1 end as `ends` says;
    the published table counts them class by class."""
    publish = load_benchmark("publish")
    config = sweep.SweepConfig(
        n=2, seed=4343, methods=["mfi", "mfi-memoryless"], world=sweep.NONCONVEX
    )
    ends = {"mfi": ("success", "trapped"), "mfi-memoryless": ("timeout", "collision")}
    records = []
    for key in config.flight_keys():
        end = ends[key.method][key.index]
        records.append(
            record_store.key_record(key)
            | {"outcome": end, "path_ratio": 1.25, "convergence_time": 30.0}
            | {"reference_length": 12.0, "straight_length": 10.0}
            | {"blocked_fraction": 0.1}
        )
    where = tmp_path / "docs" / "results" / publish.NONCONVEX
    where.mkdir(parents=True)
    summary = sweep.summarize(config, records)
    (where / "summary.json").write_text(json.dumps(summary))
    rows = publish.nonconvex_table(str(tmp_path)).splitlines()
    six = " / ".join  # a cell: the six classes
    assert rows[0].startswith(f"| seed 4343, 2 worlds a class | success {six(KINDS)} |")
    assert rows[2] == (
        f"| MFI | {six(['0.500'] * 6)} | {six('0' * 6)} | {six('0' * 6)} "
        f"| {six('1' * 6)} | {six(['1.250'] * 6)} | 30.0 |"
    )
    assert rows[3] == (
        f"| MFI (memoryless) | {six(['0.000'] * 6)} | {six('1' * 6)} | {six('1' * 6)} "
        f"| {six('0' * 6)} | {six(['–'] * 6)} | – |"
    )
    # The sweep's own table: a row a method and class, trapped included.
    table = sweep.summary_table(summary)
    assert "| mfi | cave | 2 | 0.50 [0.09, 0.91] | 0.00 [0.00, 0.66] " in table
    assert "| 0.50 [0.09, 0.91] | 1.250 [1.250, 1.250] |" in table
