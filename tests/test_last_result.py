"""LastResult: a lookup when the inputs repeat, a computation otherwise, and a
flight that logs exactly what it logs without it."""

import dataclasses
import os

import numpy as np

from mfi_drake.flight.simulation import simulate
from mfi_drake.systems import last_result
from mfi_drake.systems.last_result import LastResult
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS


def counting(calls):
    def calc(a, b):
        calls.append((a.copy(), b))
        return a * b

    return calc


def test_recomputes_only_when_the_key_changes():
    calls = []
    last = LastResult()
    calc = counting(calls)
    a = np.array([1.0, 2.0, 3.0])
    first = last((a.tobytes(), 2), calc, a, 2)
    assert last((a.copy().tobytes(), 2), calc, a, 2) is first  # a lookup
    assert len(calls) == 1
    np.testing.assert_array_equal(last((a.tobytes(), 3), calc, a, 3), a * 3)
    b = a.copy()
    b[2] = np.nextafter(b[2], 4.0)  # one ulp in one entry
    np.testing.assert_array_equal(last((b.tobytes(), 3), calc, b, 3), b * 3)
    assert len(calls) == 3


def test_disabled_always_computes():
    calls = []
    last = LastResult(enabled=False)
    calc = counting(calls)
    a = np.array([1.0, 2.0])
    last(a.tobytes(), calc, a, 2)
    last(a.tobytes(), calc, a, 2)
    assert len(calls) == 2


def test_a_flight_logs_the_same_with_and_without_it(monkeypatch):
    scenario = load_scenario(os.path.join(SCENARIOS, "planar_wall.yaml"))
    scenario = dataclasses.replace(scenario, duration=6.0)  # past the wall's edge
    remembered = simulate(scenario)
    monkeypatch.setattr(
        last_result.LastResult,
        "__init__",
        lambda self, enabled=True: setattr(self, "_enabled", False),
    )
    computed = simulate(scenario)
    np.testing.assert_array_equal(remembered.times, computed.times)
    for name, values in computed.log.items():
        np.testing.assert_array_equal(remembered.log[name], values, err_msg=name)
    assert computed.derivative_evaluations == remembered.derivative_evaluations
