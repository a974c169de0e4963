"""The scenario field `engine:` (docs/performance.md, "Engines"): a lone
vehicle flown on the compiled engine (`flight.fleet.OneIntegratorFleet` with
one vehicle) against the card's diagram of LeafSystems. Oracles: the
systems engine itself (the step API `NavigationStep` at the same inputs,
and whole flights), and the refusals' one line."""

import dataclasses
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest

from mfi_drake.app.cli import main
from mfi_drake.config.scenario import ScenarioError
from mfi_drake.flight.fleet import OneIntegratorFleet, check_engine
from mfi_drake.flight.simulation import simulate
from mfi_drake.flight.step import NavigationStep
from mfi_drake.maths import compiled, fleet, so3
from mfi_drake.maths.layout import OBSTACLE_SIGNAL_SIZE, STATE_SIZE
from mfi_drake.studies.compare import PAPER_SCENARIOS
from mfi_drake.world.validation import load_scenario

from .conftest import ROOT, SCENARIOS

WALL = f"{SCENARIOS}/planar_wall.yaml"
# The memoryless chains the compiled engine flies (the escape rule's memory:
# tests/test_escape_compiled.py).
COMPILED = ("mfi-memoryless", "mfi-paper", "apf", "gf")


def on_compiled(scenario):
    return dataclasses.replace(scenario, engine="compiled")


@pytest.fixture(scope="module")
def wall():
    return on_compiled(load_scenario(WALL))


def random_states(rng, count, away_from=None):
    """`count` random states near the planar wall's flight (heading away
    from the point `away_from`, within a few degrees, where given)."""
    for _ in range(count):
        x = np.zeros(STATE_SIZE)
        x[0:3] = [rng.uniform(0.0, 12.0), rng.uniform(-2.0, 2.0), 1.5]
        x[3:6] = rng.normal(0.0, 0.1, 3)
        x[6:9] = rng.normal(0.0, 0.8, 3)
        if away_from is not None:
            away = x[0:3] - away_from
            x[6:9] = away / np.linalg.norm(away) + rng.normal(0.0, 0.04, 3)
        x[9:12] = rng.normal(0.0, 0.3, 3)
        yield x


def assert_chain_is_the_step(scenario, method, states) -> set:
    """Asserts that the compiled chain's row equals the step API's outputs
    at each state of `states` (with 0 to 4 random obstacle points); returns
    eq 21's modes met."""
    chain = OneIntegratorFleet(scenario, method).chain
    context = chain.CreateDefaultContext()
    fixed = chain.GetInputPort("states").FixValue(context, np.zeros(STATE_SIZE))
    scene = chain.GetInputPort("scene").FixValue(
        context, np.zeros(OBSTACLE_SIGNAL_SIZE)
    )
    step = NavigationStep.from_scenario(scenario, method)
    at = fleet.row_slices()
    rng = np.random.default_rng(41)
    modes = set()
    for x in states:
        points = x[0:3] + rng.uniform(-2.0, 2.0, (rng.integers(0, 5), 3))
        step.reset()  # eq 21's mode from scratch: the chain is given it
        out = step.step(x, points)
        fixed.GetMutableData().get_mutable_value().SetFromVector(x)
        scene.GetMutableData().get_mutable_value().SetFromVector(out.obstacle)
        context.SetDiscreteState(np.array([float(out.mode)]))
        row = chain.GetOutputPort("rows").Eval(context)
        terms = row[at["obstacle_force_terms"]]
        close = dict(rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(terms[:3] + terms[3:], out.obstacle_force, **close)
        np.testing.assert_allclose(
            row[at["navigation_force"]], out.navigation_force, **close
        )
        np.testing.assert_allclose(
            row[at["attitude_setpoint"]], out.attitude_setpoint, **close
        )
        np.testing.assert_allclose(
            row[at["propeller_force"]], out.propeller_force, **close
        )
        assert row[at["mode"]][0] == out.mode
        modes.add(out.mode)
    return modes


@pytest.mark.parametrize("method", COMPILED)
def test_the_compiled_chain_gives_the_systems_outputs_at_the_same_inputs(wall, method):
    states = random_states(np.random.default_rng(40), 60)
    modes = assert_chain_is_the_step(wall, method, states)
    # Both of eq 21's modes were compared (the baselines' is always PD).
    assert modes == ({0, 1} if method.startswith("mfi") else {0})


def test_the_compiled_paper_turn_is_the_systems_where_the_goal_is_behind(wall):
    # Heading within a few degrees of straight away from the goal, mfi-paper
    # turns by eq 16–18's rotations and logarithm near π (`so3.reference_axis`
    # falls back to a fixed axis), not by the bisector's closed form.
    goal = np.array(wall.goal)
    states = list(random_states(np.random.default_rng(16), 40, away_from=goal))

    def behind(x):  # l_a and l_g too far apart for the bisector
        l_a, r_g = x[6:9] / so3.norm(x[6:9]), goal - x[0:3]
        return so3._bisector(l_a, r_g / so3.norm(r_g)) is None

    assert sum(map(behind, states)) >= 10  # measured: 37 of 40
    assert 1 in assert_chain_is_the_step(wall, "mfi-paper", states)


@pytest.mark.parametrize("seed", range(3))
def test_the_compiled_rotation_vector_is_the_python_one_at_every_angle(seed):
    # Eq 17's logarithm on each branch: β near 0, between, near π.
    rng = np.random.default_rng(seed)
    rotation_vector = compiled.compiled(so3).rotation_vector
    for beta in (1e-4, 0.5, 2.0, 3.0, np.pi - 1e-3, np.pi):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        K = so3.hat(axis)
        R = np.eye(3) + np.sin(beta) * K + (1.0 - np.cos(beta)) * K @ K
        expected = so3.rotation_vector(R)
        np.testing.assert_allclose(rotation_vector(R), expected, rtol=0, atol=1e-12)
        # The oracle: the Python form is β times the axis (its sign at π free).
        sign = np.sign(expected @ axis)
        np.testing.assert_allclose(expected, sign * beta * axis, atol=1e-6)


def test_a_lone_flight_is_the_same_on_both_engines(wall):
    # Measured: bit-identical (the same steps, positions equal) on the
    # paper's four scenes and ten random fields, with eq 21's witness
    # functions on the compiled vehicle too.
    systems = simulate(dataclasses.replace(wall, engine="systems"), until_settled=True)
    flown = simulate(wall, until_settled=True)
    assert (systems.metrics["engine"], flown.metrics["engine"]) == (
        "systems",
        "compiled",
    )
    assert flown.metrics["outcome"] == systems.metrics["outcome"] == "success"
    np.testing.assert_array_equal(flown.times, systems.times)
    assert np.abs(flown.positions - systems.positions).max() <= 1e-6


@pytest.mark.parametrize("scene", PAPER_SCENARIOS)
def test_an_mfi_flight_of_a_paper_scene_is_the_same_on_both_engines(scene):
    # The other methods' (mfi-paper, apf, gf) are flown on both engines by
    # tests/test_regression.py. Measured: bit-identical (the same steps,
    # positions equal) for every method on the paper's four scenes and on
    # tree_on_ground (mfi-paper's flight turns 43 times by eq 16–18's
    # rotations there, the goal behind).
    scenario = load_scenario(f"{SCENARIOS}/{scene}.yaml")
    systems = simulate(scenario, "mfi", until_settled=True)
    flown = simulate(on_compiled(scenario), "mfi", until_settled=True)
    assert flown.metrics["engine"] == "compiled"
    assert flown.metrics["outcome"] == systems.metrics["outcome"]
    np.testing.assert_array_equal(flown.times, systems.times)
    assert np.abs(flown.positions - systems.positions).max() <= 1e-6


def test_a_new_process_loads_the_compiled_chain_from_the_cache(wall):
    OneIntegratorFleet(wall, "mfi")  # compiled here, or loaded: on disk now
    script = (
        "import dataclasses\n"
        "from mfi_drake.flight.fleet import OneIntegratorFleet\n"
        "from mfi_drake.maths import compiled, fleet\n"
        "from mfi_drake.world.validation import load_scenario\n"
        f"s = load_scenario({WALL!r})\n"
        "OneIntegratorFleet(dataclasses.replace(s, engine='compiled'), 'mfi')\n"
        "stats = compiled.compiled(fleet).fleet_chain.stats\n"
        "print(sum(stats.cache_hits.values()), sum(stats.cache_misses.values()))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    hits, misses = map(int, done.stdout.split()[-2:])
    assert (hits, misses) == (1, 0)


def test_processes_starting_together_compile_a_function_once(tmp_path):
    """Two processes specialise the same function at the same moment in an
    empty cache: the lock makes one compile it and the other load what it
    wrote (invariant: one miss in all; numba alone compiles in each). A
    chain's lock, whose types hold a compiled field, is the same file in
    both (named by the field, not by its address in the process), and
    another field's is another."""
    script = (
        "import sys\n"
        "import numpy as np\n"
        "from mfi_drake.maths import baselines, compiled, fields, fleet, so3\n"
        "function = compiled.compiled(so3).rotation_from_reference\n"
        "chain = compiled.compiled(fleet).fleet_chain\n"
        "for field in (fields.obstacle_field, baselines.gf_obstacle_field):\n"
        "    kind = chain.typeof_pyval(compiled.compiled_form(field))\n"
        "    print(compiled._lock_path(chain, (kind,)), flush=True)\n"
        "sys.stdin.readline()\n"
        "compiled.specialised(function, np.ones(3), np.array([0.0, 1.0, 0.0]))\n"
        "print(sum(function.stats.cache_misses.values()))\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    runs = [
        subprocess.Popen(
            [sys.executable, "-c", script],
            cwd=ROOT,
            env=env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        for _ in range(2)
    ]
    # Both have imported numba once both have printed their locks' paths:
    # then both are told to start (no fixed wait for the slower import).
    paths = [[run.stdout.readline().strip() for _ in range(2)] for run in runs]
    for run in runs:
        run.stdin.write("start\n")
        run.stdin.flush()
    outs = [run.communicate(timeout=120)[0].split() for run in runs]
    assert sorted(int(out[-1]) for out in outs) == [0, 1]
    mfi, gf = paths[0]
    assert paths[1] == [mfi, gf] and mfi != gf


def test_the_cache_falls_back_to_the_user_directory_where_the_package_is_read_only(
    monkeypatch,
):
    from numba.core import caching, config

    def read_only(self):
        raise OSError("read-only file system")

    monkeypatch.setattr(config, "CACHE_DIR", "")
    monkeypatch.setattr(caching.InTreeCacheLocator, "ensure_cache_path", read_only)
    function = compiled.compiled(fleet).fleet_chain.py_func
    locator = compiled._cache_class()(function)._impl.locator
    assert isinstance(locator, caching.UserWideCacheLocator)
    assert locator.get_source_stamp() == compiled._sources_stamp()


def test_a_new_stamp_prunes_the_stale_stamps_of_its_cache_directory(
    tmp_path, monkeypatch
):
    from numba.core import config

    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path))  # numba's first
    function = compiled.compiled(fleet).fleet_chain.py_func
    ours = compiled._cache_class()(function)._impl.locator.get_cache_path()
    parent = os.path.dirname(ours)
    old = time.time() - compiled.PRUNE_AFTER - 60.0

    def made(name: str, written: float | None = None) -> str:
        path = os.path.join(parent, name)
        os.makedirs(path)
        with open(os.path.join(path, "index.nbi"), "w") as f:
            f.write("cached")
        if written is not None:
            for entry in (os.path.join(path, "index.nbi"), path):
                os.utime(entry, (written, written))
        return path

    stale = made("mfi_drake-0123456789abcdef", old)
    recent = made("mfi_drake-fedcba9876543210")  # maybe compiling now
    foreign = [made("numba-0123456789abcdef", old), made("mfi_drake-stale", old)]
    shutil.rmtree(ours)
    compiled._cache_class()(function)  # the first function of its stamp here
    assert os.path.isdir(ours) and not os.path.exists(stale)
    assert all(map(os.path.isdir, [recent, *foreign]))
    # A stamp already there prunes nothing.
    stale = made("mfi_drake-0123456789abcdef", old)
    compiled._cache_class()(function)
    assert os.path.isdir(stale)


@pytest.mark.parametrize(
    "argv, named",
    [
        (["run", WALL, "--set", "engine: fast"], "engine = 'fast': must be one of"),
        (
            [
                *("run", f"{SCENARIOS}/swarm_corridor.yaml", "--method", "mfi-nc"),
                *(
                    "--set",
                    "fleet_integration: one",
                    "--set",
                    "sensor: !DepthCamera {}",
                ),
            ],
            "fleet_integration = 'one': sensor: the compiled chain flies the sphere",
        ),
        (
            ["run", f"{SCENARIOS}/swarm_corridor.yaml", "--set", "engine: compiled"],
            "a fleet flies compiled on one integrator",
        ),
        (["analyze", WALL, "--set", "engine: compiled"], "analyze linearises"),
    ],
)
def test_what_the_compiled_engine_cannot_fly_is_refused_by_name(
    tmp_path, capsys, argv, named
):
    assert main([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert named in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_the_engine_refusal_names_the_scenario_and_the_other_engine(wall):
    cameras = load_scenario(WALL, [("cameras", "sensor: !DepthCamera {}")])
    with pytest.raises(ScenarioError, match=r"sensor: .*\(engine: systems flies it\)"):
        check_engine(on_compiled(cameras), ["mfi"])
