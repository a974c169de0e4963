"""Every script in examples/ runs as a user runs it (a subprocess, from a
scratch directory, writing nothing there) and prints what its docstring
says, checked against an independent oracle: the same scene flown by
`simulate`, the height loop's closed-form eigenvalues, the closed-form
clearance of the spheres."""

import glob
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from mfi_drake import NavigatorParams, load_scenario, simulate
from mfi_drake.config.vehicles import VEHICLES

from .conftest import ROOT

EXAMPLES = sorted(glob.glob(os.path.join(ROOT, "examples", "*.py")))
NUMBER = r"([-+]?\d+\.\d+(?:e[-+]\d+)?)"


def run(script: str, tmp_path, *arguments: str) -> str:
    done = subprocess.run(
        [sys.executable, script, "--duration", "20", *arguments],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
        env=os.environ | {"PYTHONPATH": ROOT, "PYTHONDONTWRITEBYTECODE": "1"},
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert not list(tmp_path.iterdir())  # it wrote nothing
    return done.stdout


def numbers(pattern: str, text: str) -> list[float]:
    match = re.search(pattern.replace("NUMBER", NUMBER), text)
    assert match, (pattern, text)
    return [float(g) for g in match.groups()]


@pytest.fixture(scope="module")
def yard_flight():
    """The examples' yard as a scenario's obstacles, flown by `simulate`."""
    path = os.path.join(ROOT, "tests", "data", "yard.yaml")
    return simulate(load_scenario(path)).metrics


def yard_outcome(out: str, request) -> None:
    metrics = request.getfixturevalue("yard_flight")
    reached, error, clearance = numbers(
        r"reached the goal at t = NUMBER s: .* distance to the goal NUMBER m, "
        r"least clearance NUMBER m",
        out,
    )
    # The sensor's nearest reading is SceneGraph's exact distance (within
    # its radius), as the metrics' clearance; printed to 3 decimals.
    assert clearance == pytest.approx(metrics["min_clearance"], abs=1.5e-3)
    assert reached == pytest.approx(metrics["convergence_time"], abs=0.02)
    assert 0.0 < clearance < 1.0 and error < 0.1


def check_own_diagram(out: str, request) -> None:
    yard_outcome(out, request)


def check_multibody_vehicle(out: str, request) -> None:
    yard_outcome(out, request)  # two plants, one physics: the same outcome


def spheres_outcome(out: str) -> None:
    error, clearance = numbers(
        r"reached the goal: t = .* final error NUMBER m, least clearance NUMBER m",
        out,
    )
    assert error < 0.1 and 0.0 < clearance < 1.0  # it flew among the spheres


def check_step_loop(out: str, _) -> None:
    spheres_outcome(out)
    assert "eq 21 mode cruise" in out


def check_own_sensor(out: str, _) -> None:
    spheres_outcome(out)


def check_analysis(out: str, _) -> None:
    found = re.findall(rf"eigenvalue\s+{NUMBER}\s+{NUMBER}j", out)
    eigenvalues = np.array([complex(float(a), float(b)) for a, b in found])
    assert len(eigenvalues) == 12 and np.all(np.isfinite(eigenvalues))
    assert np.all(eigenvalues.real < 0.0)
    # Hand oracle: the height loop is eq 20's PD on the mass alone (thrust
    # acts on z directly), m λ² + K_D λ + K_P = 0.
    params, mass = NavigatorParams(), VEHICLES["drake_default"].mass
    for root in np.roots([mass, params.K_D, params.K_P]):
        assert np.abs(eigenvalues - root).min() < 1e-4
    (difference,) = numbers(r"\|A_Linearize - A_fd\| max NUMBER", out)
    assert difference < 1e-6
    offset, linear_error = numbers(
        r"\|x - x0\| NUMBER, linear model off by NUMBER", out
    )
    assert linear_error < offset


def check_rotorpy_crazyflie(out: str, _) -> None:
    """rotorpy's Crazyflie reaches the goal without contact; the oracle is
    the same world flown by mfi_drake's own simulation (its printed second
    line): the two models differ (rotor drag, motor lag on rotor speed),
    so clearance and path agree to within 3 cm and 10 %."""
    pattern = (
        r"NAME: reached the goal at t = NUMBER s, least clearance NUMBER m, "
        r"path length NUMBER m"
    )
    _, clearance, length = numbers(pattern.replace("NAME", "rotorpy"), out)
    _, own_clearance, own_length = numbers(pattern.replace("NAME", "mfi_drake"), out)
    assert clearance > 0.0 and own_clearance > 0.0
    assert clearance == pytest.approx(own_clearance, abs=0.03)
    assert length == pytest.approx(own_length, rel=0.1)


@pytest.mark.parametrize(
    "script", EXAMPLES, ids=[os.path.basename(p) for p in EXAMPLES]
)
def test_the_example_runs_and_prints_its_outcome(script, tmp_path, request):
    name = os.path.basename(script)[: -len(".py")]
    check = globals().get(f"check_{name}")
    assert check, f"examples/{name}.py: add check_{name} to this file"
    check(run(script, tmp_path), request)
