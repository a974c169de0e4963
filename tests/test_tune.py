"""`mfi-drake tune`: the same budget and training fields for every method,
held-out seeds that must differ from the training ones, an override file
that run accepts, and a search that finds a toy method's known best gain."""

import hashlib
import json
import os
import sys
import textwrap

import numpy as np
import pytest
import yaml

from mfi_drake import load_scenario
from mfi_drake.app.cli import main
from mfi_drake.config import scenario as sc
from mfi_drake.config.parameters import GfParams, NavigatorParams
from mfi_drake.flight.methods import METHODS, Gain
from mfi_drake.studies.compare import PAPER_SCENARIOS
from mfi_drake.studies.records import read_results
from mfi_drake.studies.tune import (
    TuneConfig,
    TuneError,
    training_fields,
    tune,
    tune_held_out,
)
from mfi_drake.studies.tune_search import (
    gain_values,
    latin_hypercube,
    override_text,
    unit_point,
)

from .conftest import SCENARIOS

# A toy method whose best gain is known: it cruises at 1.5 − (k − 2)² m/s
# (at least 0.3) straight to the goal, so on an empty field every k succeeds
# with path ratio 1 and the earliest arrival, the objective's last word, is
# at k = 2.
TOY = textwrap.dedent(
    """
    import numpy as np

    def cruise(position, velocity, obstacle_points, goal, k=1.0):
        to_goal = goal - position
        distance = np.linalg.norm(to_goal)
        speed = max(0.3, 1.5 - (k - 2.0) ** 2) * min(1.0, distance)
        wanted = speed * to_goal / max(distance, 1e-9)
        return 3.0 * (wanted - velocity)

    cruise.gains = {"k": (0.5, 4.0)}
    """
)


@pytest.fixture
def toy_dir(module_dir):
    (module_dir / "toy.py").write_text(TOY)
    return module_dir


def test_gain_points_round_trip_and_fractions_stay_below():
    gains = METHODS["gf"].gains
    rng = np.random.default_rng(0)
    for unit in latin_hypercube(rng, 20, len(gains)):
        values = gain_values(gains, unit)
        np.testing.assert_allclose(unit_point(gains, values), unit, atol=1e-12)
        assert values["gf.rho_0"] < values["gf.r_d"]  # ρ₀ < r_d, as GF needs
        for gain in gains:
            if gain.fraction_of is None:
                assert gain.low <= values[gain.path] <= gain.high


def test_latin_hypercube_has_one_point_in_every_stratum():
    points = latin_hypercube(np.random.default_rng(3), 8, 4)
    for column in points.T:
        assert sorted(np.floor(column * 8).astype(int)) == list(range(8))


def test_override_text_layers_onto_a_scenario():
    text = override_text({"navigator.c": 2.5, "gf.attraction.k_att": 1.25})
    scenario = load_scenario(
        os.path.join(SCENARIOS, "planar_wall.yaml"), [("tune", text)]
    )
    assert scenario.navigator.c == 2.5 and scenario.gf.attraction.k_att == 1.25
    assert scenario.navigator.r_l == NavigatorParams().r_l  # untouched


def test_same_budget_and_fields_for_every_method_and_toy_optimum(
    toy_dir, threads_client
):
    config = TuneConfig(
        methods=["toy:cruise", "gf"],
        candidates=9,
        seed=100,
        n=2,
        densities=[0.0],
        out=str(toy_dir / "tune"),
    )
    best = tune(config, threads_client, progress_stream=None)
    records = read_results(str(toy_dir / "tune" / "tune.jsonl"))
    flown = {
        m: sorted(r["scenario"] for r in records if r["method"] == m) for m in best
    }
    # Every method: candidates × fields flights, on the same fields.
    assert all(len(v) == 9 * 2 for v in flown.values())
    assert flown["toy:cruise"] == flown["gf"]
    # Both on the compiled engine: numba compiles the user's field too.
    engines = {m: {r["engine"] for r in records if r["method"] == m} for m in best}
    assert engines == {"toy:cruise": {"compiled"}, "gf": {"compiled"}}
    # The toy's optimum is k = 2 (cruise at 1.5 m/s); 9 candidates of a
    # 1-D search over [0.5, 4] get within 0.25 of it.
    assert best["toy:cruise"].values["field_gains.k"] == pytest.approx(2.0, abs=0.25)
    # Candidate 0 is each method's defaults (GF's scenario gains).
    first_gf = [r for r in records if r["method"] == "gf" and r["candidate"] == 0]
    assert first_gf[0]["gains"]["gf.k_g"] == GfParams().k_g
    # A rerun flies nothing new and finds the same winners.
    again = tune(config, threads_client, progress_stream=None)
    assert len(read_results(str(toy_dir / "tune" / "tune.jsonl"))) == len(records)
    assert set(os.listdir(toy_dir / "tune")) == {  # no mesh files
        "tune.jsonl", "tuned.yaml", "tuning.json", "tuning.md"
    }  # fmt: skip
    assert {m: c.values for m, c in again.items()} == {
        m: c.values for m, c in best.items()
    }
    # The override file is accepted by run, and flies the winning gain.
    tuned = toy_dir / "tune" / "tuned.yaml"
    out = toy_dir / "run"
    scenario = os.path.join(SCENARIOS, "planar_wall.yaml")
    args = ["run", scenario, "--method", "toy:cruise", "--override", str(tuned)]
    assert main([*args, "--out", str(out), "--set", "obstacles: []"]) == 0
    layered = load_scenario(scenario, [(str(tuned), tuned.read_text())])
    assert layered.field_gains == {"k": best["toy:cruise"].values["field_gains.k"]}
    assert layered.gf.k_g == best["gf"].values["gf.k_g"]


def test_the_held_out_protocol_runs_from_python(toy_dir, threads_client):
    """`tune_held_out`: the winners of tuned.yaml flown on the held-out seed's
    fields, keyed by the override file's variant, where the CLI puts them."""
    config = TuneConfig(
        methods=["toy:cruise"],
        candidates=3,
        seed=100,
        n=1,
        densities=[0.0],
        held_out_seed=101,
        out=str(toy_dir / "tune"),
    )
    best, run = tune_held_out(config, threads_client, 2, [0.0], sys.stdout)
    tuned = (toy_dir / "tune" / "tuned.yaml").read_text()
    k = best["toy:cruise"].values["field_gains.k"]
    assert yaml.safe_load(tuned) == {"field_gains": {"k": k}}
    records = read_results(str(toy_dir / "tune" / "held_out" / "results.jsonl"))
    assert (run.ran, run.skipped, run.lost) == (2, 0, [])
    assert sorted((r["seed"], r["index"], r["method"]) for r in records) == [
        (101, 0, "toy:cruise"),
        (101, 1, "toy:cruise"),
    ]
    # The variant names the override file by its name and a hash of its text.
    digest = hashlib.sha1(tuned.encode()).hexdigest()[:8]
    assert {r["variant"] for r in records} == {f"tuned.yaml@{digest}"}
    # Empty fields: the toy flies straight to the goal at any gain.
    assert all(r["outcome"] == "success" for r in records)
    assert run.summary["methods"]["toy:cruise"]["success_rate"] == 1.0
    # Without a held-out seed: the tuning alone, no held-out sweep.
    config.held_out_seed = None
    again, none = tune_held_out(config, threads_client, progress_stream=sys.stdout)
    assert none is None and again["toy:cruise"].values == best["toy:cruise"].values


def test_the_held_out_phase_flies_generated_worlds(toy_dir, threads_client):
    """`held_out_world`: the winners flown on the sweep's generated worlds of
    the held-out seed (here one cup), recorded by class, with no density."""
    config = TuneConfig(
        methods=["toy:cruise"],
        candidates=3,
        n=1,
        densities=[0.0],
        held_out_seed=101,
        held_out_world="cup",
        out=str(toy_dir / "tune_world"),
    )
    _, run = tune_held_out(config, threads_client, 1, progress_stream=sys.stdout)
    records = read_results(str(toy_dir / "tune_world" / "held_out" / "results.jsonl"))
    assert [(r["world"], r["density"], r["seed"], r["index"]) for r in records] == [
        ("cup", None, 101, 0)
    ]
    assert run.summary["config"]["densities"] == []
    assert list(run.summary["methods"]["toy:cruise"]["by_world"]) == ["cup"]


def test_a_held_out_density_with_a_generated_world_is_refused(tmp_path, capsys):
    args = ["tune", "--held-out-seed", "5", "--held-out-world", "cup"]
    args += ["--held-out-density", "0.1", "--out", str(tmp_path)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--held-out-density = 0.1" in err
    assert "--held-out-world cup" in err and not any(tmp_path.iterdir())
    with pytest.raises(TuneError, match="--held-out-world = moon"):
        TuneConfig(methods=["mfi"], held_out_world="moon").check()


def test_overlapping_held_out_seed_is_refused(tmp_path, capsys):
    args = ["tune", "--seed", "7", "--held-out-seed", "7", "--out", str(tmp_path)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--held-out-seed = 7" in err
    assert not any(tmp_path.iterdir())
    with pytest.raises(TuneError):
        TuneConfig(methods=["mfi"], seed=3, held_out_seed=3).check()


def test_wall_fields_join_the_training_fields_and_a_negative_count_is_refused(
    tmp_path, capsys
):
    config = TuneConfig(
        methods=["gf"], n=1, densities=[0.1], walls=2, out=str(tmp_path)
    )
    names = [s.name for s in training_fields(config)]
    assert names == ["field_d0.1_s100_i0", "wall_s100_i0", "wall_s100_i1"]
    assert main(["tune", "--walls", "-1", "--out", str(tmp_path / "t")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--walls = -1" in err
    assert not (tmp_path / "t").exists()


def test_paper_scenarios_join_the_training_fields_self_contained(tmp_path):
    """Their mesh files' vertices inline: a remote worker reads no file."""
    config = TuneConfig(
        methods=["gf"], n=1, densities=[0.1], paper_scenarios=SCENARIOS,
        out=str(tmp_path),
    )  # fmt: skip
    fields = training_fields(config)
    assert [s.name for s in fields[1:]] == list(PAPER_SCENARIOS)
    convex = [o.shape for s in fields for o in s.obstacles
              if isinstance(o.shape, sc.Convex)]  # fmt: skip
    assert convex and all(c.vertices and not c.file for c in convex)
    assert all(s.base_dir == "" for s in fields)


def test_moving_fields_join_the_training_fields_and_bad_motion_is_refused(
    tmp_path, capsys
):
    """--moving: each random field again, named *_moving, its obstacles
    those of the static field with round(share × count) of them circling."""
    config = TuneConfig(
        methods=["gf"], n=2, densities=[0.1], moving=0.3, obstacle_speed=0.5,
        out=str(tmp_path),
    )  # fmt: skip
    fields = training_fields(config)
    names = [s.name for s in fields]
    assert names == [
        "field_d0.1_s100_i0", "field_d0.1_s100_i1",
        "field_d0.1_s100_i0_moving", "field_d0.1_s100_i1_moving",
    ]  # fmt: skip
    for static, moving in zip(fields[:2], fields[2:], strict=True):
        assert [o.position for o in moving.obstacles] == [
            o.position for o in static.obstacles
        ]
        assert not any(o.motion for o in static.obstacles)
        circling = sum(bool(o.motion) for o in moving.obstacles)
        assert 0 < circling <= round(0.3 * len(static.obstacles))
    for flags, named in (
        (["--moving", "1.5"], "--moving = 1.5"),
        (["--moving", "0.3"], "--obstacle-speed = 0.0"),
    ):
        assert main(["tune", *flags, "--out", str(tmp_path / "t")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and named in err
    assert not (tmp_path / "t").exists()


def test_jittered_copies_start_a_millimetre_apart_and_bad_jitter_is_refused(
    tmp_path, capsys
):
    """--jitter K: each random field (moving too) K times, the copies started
    1 mm away along +x, −x, +y, … in turn, all else the same; walls and the
    paper's scenes once."""
    config = TuneConfig(
        methods=["gf"], n=1, densities=[0.1], moving=0.3, obstacle_speed=0.5,
        walls=1, jitter=3, out=str(tmp_path),
    )  # fmt: skip
    fields = {s.name: s for s in training_fields(config)}
    static, moving = "field_d0.1_s100_i0", "field_d0.1_s100_i0_moving"
    assert list(fields) == [
        static, moving,
        f"{static}_jitter+1+0+0", f"{static}_jitter-1+0+0",
        f"{moving}_jitter+1+0+0", f"{moving}_jitter-1+0+0",
        "wall_s100_i0",
    ]  # fmt: skip
    for base in (static, moving):
        for name, step in (("+1+0+0", 1e-3), ("-1+0+0", -1e-3)):
            copy = fields[f"{base}_jitter{name}"]
            offset = np.subtract(copy.start, fields[base].start)
            assert offset == pytest.approx([step, 0.0, 0.0], abs=1e-12)
            assert copy.goal == fields[base].goal
            assert copy.obstacles == fields[base].obstacles
    for bad in ("0", "8"):
        assert main(["tune", "--jitter", bad, "--out", str(tmp_path / "t")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"--jitter = {bad}" in err
    assert not (tmp_path / "t").exists()


def test_a_method_without_gains_is_refused(toy_dir, threads_client):
    (toy_dir / "plain.py").write_text(
        "def field(position, velocity, obstacle_points, goal):\n    return 0 * goal\n"
    )
    config = TuneConfig(methods=["plain:field"], out=str(toy_dir / "t"))
    with pytest.raises(TuneError, match="declares no free gains"):
        tune(config, threads_client, progress_stream=None)


def test_every_builtin_method_declares_gains_with_valid_ranges():
    for method in METHODS.values():
        assert method.gains, method.name
        for gain in method.gains:
            assert isinstance(gain, Gain) and 0 < gain.low < gain.high
            assert gain.path.split(".")[0] == method.parameters
    assert json.loads(override_text({"a.b": 1.0})) == {"a": {"b": 1.0}}
