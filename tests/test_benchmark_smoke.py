"""benchmarks/throughput.py runs and reports what it claims (no timing
assertions: the numbers depend on the machine)."""

import os

import pytest

from .conftest import ROOT, load_benchmark

# Any override file: part 4 flies the same fields again with it layered on.
OVERRIDE = os.path.join(ROOT, "tests", "data", "gains_override.yaml")


def test_throughput_prints_every_part_and_writes_the_page(capsys, tmp_path):
    page = tmp_path / "performance.md"
    page.write_text("# P\n<!-- BEGIN throughput -->\nold\n<!-- END throughput -->\n")
    argv = ["--duration", "2.0", "--repeats", "1", "--split", "1", "--fields", "1"]
    argv += ["--compare", "1", "--scenarios", "sharp_*.yaml"]
    # Fixed fields (the time's seed varied the test's CPU by 2x with them):
    # every method flies parts 3 and 4's (seeds 10 and 9) to its goal in
    # ~20 s simulated, the cheap end of seeds 1-10.
    argv += ["--seed", "6"]
    argv += ["--override", OVERRIDE]
    result = load_benchmark("throughput").main(argv + ["--page", str(page)])
    out = capsys.readouterr().out
    for text in ("MFI (Python", "C++ QuadrotorPlant + LQR", "ratio", "flights/min"):
        assert text in out
    # The floor: the same diagram with stale results, and the per-step
    # cost the 0.05 bar allows: the C++ diagram's CPU over 0.05 × MFI's steps.
    assert "stale results" in out and result["floor"].steps > 0
    allowed = result["lqr"].cpu_time / 0.05 / result["mfi"].steps
    assert result["allowed_per_step"] == pytest.approx(allowed)
    # Part 4: every compared method, and GF's ratio to itself is 1; with
    # --override, the same fields again with the file layered on.
    assert set(result["methods"]) == {"mfi", "mfi-paper", "apf", "gf"}
    assert set(result["overridden"]) == set(result["methods"])
    assert "with " + OVERRIDE in out
    assert all(cpu > 0.0 for cpu in result["methods"].values())
    assert "x1.00 GF's" in out
    for text in ("4. CPU per flight by method", "5. every shipped scenario"):
        assert text in out
    (factor,) = result["scenarios"].values()
    assert list(result["scenarios"]) == ["sharp_corner"] and factor > 0.0
    mfi, lqr = result["mfi"], result["lqr"]
    assert mfi.sim_time == pytest.approx(2.0)
    assert lqr.sim_time == pytest.approx(2.0)
    assert result["ratio"] == pytest.approx(mfi.realtime_factor / lqr.realtime_factor)
    assert f"{result['ratio']:.4f}" in out
    # The compiled engine beside them, and the whole command on each engine.
    fast = result["compiled"]
    assert "MFI (compiled engine)" in out and fast.sim_time == pytest.approx(2.0)
    assert result["compiled_ratio"] == pytest.approx(
        fast.realtime_factor / lqr.realtime_factor
    )
    assert f"compiled / C++: {result['compiled_ratio']:.4f}" in out
    # The sensor's queries: at least one a step (the vehicle moves), at most
    # one a derivative evaluation and two more (the step's start, the log).
    floor, evaluations = result["compiled_floor"], fast.derivative_evaluations
    assert 1.0 <= floor["queries_per_step"] <= evaluations / fast.steps + 2.0
    assert floor["query"] > 0.0 and "distance queries per step" in out
    # Python systems that pass the LQR's command on change no step of it.
    for run in floor["passed_through"].values():
        assert (run.steps, run.derivative_evaluations) == (
            lqr.steps,
            lqr.derivative_evaluations,
        )
    assert "Python systems that compute nothing" in out
    for engine in ("systems", "compiled"):
        wall, factor = result["commands"][engine]
        assert wall > 2.0 / factor  # the command holds the flight and more
        assert f"`mfi-drake run --json` on {engine}" in out
    # RK3 evaluates the derivatives three times per attempted step, and
    # rejected steps are attempted again: at least three per accepted step.
    for run in (mfi, lqr):
        assert run.steps > 0
        assert run.derivative_evaluations >= 3 * run.steps
    assert set(result["split"]) == {
        "generate",
        "yaml",
        "reference",
        "build",
        "simulate",
        "metrics",
    }
    assert result["split"]["simulate"] > 0.0
    # Part 3: the sweep command on each engine (each run checks that its
    # records name the engine it was meant to fly).
    assert set(result["rates"]) == {
        "mfi, 1 worker, compiled",
        "mfi, 2 workers, compiled",
        "every method, 2 workers, systems",
        "every method, 2 workers, compiled",
    }
    assert min(result["rates"].values()) > 0.0
    assert "compiled / systems: x" in out
    written = page.read_text()
    assert "old" not in written and "flights/min" in written
    assert written.startswith("# P\n<!-- BEGIN throughput -->\n```\ncommit ")


def test_throughput_rejects_a_non_positive_duration():
    with pytest.raises(SystemExit) as error:
        load_benchmark("throughput").main(["--duration", "0"])
    assert error.value.code == 2


def test_stale_results_hand_back_the_first_result_and_are_undone():
    module = load_benchmark("throughput")
    from mfi_drake.systems.last_result import LastResult

    calls = []

    def square(x):
        calls.append(x)
        return x * x

    last = LastResult()
    with module.StaleResults(refresh=3):
        got = [last(k, square, k) for k in (1, 2, 3, 4, 5)]
    # Computed at the 1st call and again after 3 stale ones.
    assert got == [1, 1, 1, 16, 16] and calls == [1, 4]
    assert last(6, square, 6) == 36  # outside the block: computed as usual
    assert last(6, square, 6) == 36 and calls == [1, 4, 6]


def test_fleet_conflicts_writes_its_table_and_the_rule_turns_the_roundabout(
    tmp_path, capsys
):
    # Two vehicles head-on: without the rule both swerve left (the head-on
    # tangent's bias), so they circle the middle clockwise; with it, right
    # and anticlockwise. Either way one side each: a roundabout.
    page = tmp_path / "page.md"
    page.write_text("<!-- BEGIN fleet_conflicts -->\n<!-- END fleet_conflicts -->\n")
    argv = ["--sizes", "2", "--methods", "mfi", "--keep-right", "0,60"]
    load_benchmark("fleet_conflicts").main(
        argv + ["--processes", "1", "--page", str(page)]
    )
    (row,) = [line for line in page.read_text().splitlines() if line.startswith("| 2 ")]
    without, with_rule = row.strip(" |").split(" | ")[2:]
    assert without.startswith("success, ") and without.endswith(", −−")
    assert with_rule.startswith("success, ") and with_rule.endswith(", ++")


def test_fleet_scaling_compiled_writes_both_scenes_against_the_lone_vehicle(
    tmp_path,
):
    page = tmp_path / "page.md"
    page.write_text("<!-- BEGIN fleet_compiled -->\n<!-- END fleet_compiled -->\n")
    argv = ["--sizes", "", "--rates", "", "--compiled", "2", "--field-seconds", "1"]
    load_benchmark("fleet_scaling").main(argv + ["--page", str(page)])
    rows = [line.strip(" |").split(" | ") for line in page.read_text().splitlines()]
    rows = [row for row in rows if len(row) == 9 and row[1] == "2"]
    assert [row[0].split(" (")[0] for row in rows] == ["circle", "field 0/0"]
    assert rows[1][0].endswith("(20 obstacles)")
    for row in rows:
        cpu, alone, ratio = (float(x) for x in row[4:7])
        # As printed: both rates to 0.1 (each off by up to 0.05), the ratio
        # to 0.01, so the ratio of the printed rates may be off by more.
        slack = cpu / alone * (0.05 / cpu + 0.05 / alone) + 0.005
        assert ratio == pytest.approx(cpu / alone, abs=slack + 1e-9)
    assert "The whole command: " in page.read_text()
