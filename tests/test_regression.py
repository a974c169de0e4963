"""The paper scenarios fly as they did before the package was restructured:
every metric of every method equal to the recorded one to 1e-9 (timings
aside). tests/data/paper_metrics.json holds the record, written by the code
before the restructure (commit bf3fe44, `mfi-drake compare SCENARIO --json`),
and the gains it was flown with, which the test layers on each scenario (so
that tuned defaults do not move it). The paper's MFI of then is today's
"mfi-paper" (every repair off). A change that is meant to move these flights
regenerates the record with `python -m tests.test_regression` and says why
in its commit."""

import json
import os
import sys

import pytest

from mfi_drake import load_scenario
from mfi_drake.studies.compare import compare

from .conftest import ROOT, SCENARIOS

RECORDED = os.path.join(ROOT, "tests", "data", "paper_metrics.json")
TIMINGS = ("wall_time", "realtime_factor")
with open(RECORDED) as f:
    RECORD = json.load(f)
EXPECTED = RECORD["metrics"]


def flown(name: str) -> dict:
    gains = ("recorded gains", json.dumps(RECORD["gains"]))
    scenario = load_scenario(os.path.join(SCENARIOS, f"{name}.yaml"), [gains])
    flights = compare(scenario, list(EXPECTED[name]))
    return {
        f.method: {k: v for k, v in f.metrics.items() if k not in (*TIMINGS, "method")}
        for f in flights
    }


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_paper_scenario_metrics_are_unchanged(name):
    for method, got in flown(name).items():
        for key, want in EXPECTED[name][method].items():
            if isinstance(want, float):
                assert got[key] == pytest.approx(want, rel=1e-9, abs=1e-9), key
            else:
                assert got[key] == want, (method, key)


if __name__ == "__main__":  # regenerate the record from the current code
    RECORD["metrics"] = {n: flown(n) for n in EXPECTED}
    with open(RECORDED, "w") as f:
        json.dump(RECORD, f, indent=1, sort_keys=True)
    print(f"wrote {RECORDED}", file=sys.stderr)
