"""benchmarks/flight_speed.py runs and reports what it claims (no timing
assertions: the numbers depend on the machine)."""

import importlib.util
import os

import pytest

from .conftest import ROOT


def load_benchmark():
    path = os.path.join(ROOT, "benchmarks", "flight_speed.py")
    spec = importlib.util.spec_from_file_location("flight_speed", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_flight_speed_prints_both_runs_and_their_ratio(capsys):
    result = load_benchmark().main(["--duration", "2.0", "--repeats", "1"])
    out = capsys.readouterr().out
    for text in ("MFI flight", "LQR reference", "x real time", "ratio"):
        assert text in out
    mfi, lqr = result["mfi"], result["lqr"]
    assert mfi.sim_time == pytest.approx(2.0)
    assert lqr.sim_time == pytest.approx(2.0)
    assert result["ratio"] == pytest.approx(mfi.realtime_factor / lqr.realtime_factor)
    assert f"{result['ratio']:.4f}" in out
    # RK3 evaluates the derivatives three times per attempted step, and
    # rejected steps are attempted again: at least three per accepted step.
    for run in (mfi, lqr):
        assert run.steps > 0
        assert run.derivative_evaluations >= 3 * run.steps


def test_flight_speed_rejects_a_non_positive_duration():
    with pytest.raises(SystemExit) as error:
        load_benchmark().main(["--duration", "0"])
    assert error.value.code == 2
