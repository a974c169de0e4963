"""`sensor.readings` on the compiled engine and on one integrator: a count
other than the default sizes the compiled chain's arrays, rows and
memories. Oracles: the systems engine (whole flights), each vehicle's own
single-vehicle diagram (the chain's rows at one instant) and separate
integration (a fleet's flight), all at the same count."""

import dataclasses

import numpy as np
import pytest

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import OtherVehicle
from mfi_drake.flight.fleet import OneIntegratorFleet
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths import compiled, escape, fields, fleet
from mfi_drake.maths.layout import READING_SIZE, signal_size
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS
from .test_one_integrator import crowded_fleet, single_vehicle_rows
from .test_user_compiled import as_tuple

COUNT = 5  # more than the default 3
# Six spheres about the line from the start to the goal: up to five readings
# at once within eq 13's reach r_l (measured: flown with 3 readings, the
# path is another).
CLUSTER = [
    (3.0, 0.8, 1.5),
    (3.0, -0.8, 1.5),
    (4.0, 0.0, 2.6),
    (4.0, 0.2, 0.5),
    (5.5, -0.6, 1.8),
    (5.5, 0.7, 1.2),
]


def with_count(scenario: sc.Scenario, count: int = COUNT) -> sc.Scenario:
    return dataclasses.replace(
        scenario, sensor=dataclasses.replace(scenario.sensor, readings=count)
    )


def cluster(lanes: tuple[float, ...] = ()) -> sc.Scenario:
    """A vehicle through CLUSTER along y = 0, and one more along each y of
    `lanes` (a fleet), at COUNT readings."""
    return sc.Scenario(
        name="cluster",
        start=[0.0, 0.0, 1.5],
        goal=[8.0, 0.0, 1.5],
        duration=25.0,
        sensor=sc.SphereSensor(radius=3.0, readings=COUNT),
        obstacles=[sc.Obstacle(sc.Sphere(0.3), list(p)) for p in CLUSTER],
        other_vehicles=[
            OtherVehicle(start=[0.0, y, 1.5], goal=[8.0, y, 1.5]) for y in lanes
        ],
    )


def most_within_reach(flight) -> int:
    """The most readings of a flight's logged "obstacle" seen at once within
    eq 13's reach r_l: more than 3 make the count matter."""
    obstacle = flight.log["obstacle"]
    readings = obstacle.reshape(len(obstacle), -1, READING_SIZE)
    reach = flight.scenario.navigator.r_l
    near = np.linalg.norm(readings[:, :, :3], axis=2) < reach
    return int((near & (readings[:, :, 3] > 0.5)).sum(axis=1).max())


@pytest.mark.parametrize(
    "method, count", [("mfi", COUNT), ("mfi-memoryless", COUNT), ("mfi", 1)]
)
def test_a_lone_flight_of_another_count_is_the_same_on_both_engines(method, count):
    # mfi: the escape memory of `count` readings; mfi-memoryless: the field
    # alone. Measured: bit-identical, as at the default count
    # (tests/test_engine.py).
    scenario = with_count(cluster(), count)
    systems = simulate(scenario, method, until_settled=True)
    on_compiled = dataclasses.replace(scenario, engine="compiled")
    fast = simulate(on_compiled, method, until_settled=True)
    assert fast.metrics["engine"] == "compiled"
    assert fast.log["obstacle"].shape[1] == signal_size(count)
    assert most_within_reach(fast) >= min(count, 4)  # 5: more than 3 act
    assert fast.metrics["outcome"] == systems.metrics["outcome"] == "success"
    np.testing.assert_array_equal(fast.times, systems.times)
    assert np.abs(fast.positions - systems.positions).max() <= 1e-6


def test_faults_among_moving_obstacles_fly_five_readings_alike():
    """The velocity estimator's, the faults' and the logged truth's ports
    of 5 readings (`TrueRows`) on the compiled engine, against systems."""
    scenario = load_scenario(
        f"{SCENARIOS}/moving_crossing.yaml",
        [("faults", "faults: {sensor_noise_std: 0.05, dropout_prob: 0.1, seed: 7}")],
    )
    scenario = with_count(dataclasses.replace(scenario, duration=5.5))
    systems = simulate(scenario, "gf")
    fast = simulate(dataclasses.replace(scenario, engine="compiled"), "gf")
    assert (fast.log["obstacle"][:, 3] > 0.5).any()  # a moving obstacle seen
    np.testing.assert_array_equal(fast.times, systems.times)
    for key, values in systems.log.items():
        np.testing.assert_array_equal(fast.log[key], values, err_msg=key)


def test_a_users_field_reads_five_readings_on_both_engines():
    # as_tuple's F_n counts the obstacle points it is given: 4 or 5 here.
    scenario = dataclasses.replace(cluster(), duration=6.0)
    systems = simulate(scenario, as_tuple)
    fast = simulate(dataclasses.replace(scenario, engine="compiled"), as_tuple)
    assert fast.metrics["engine"] == "compiled"
    assert fast.log["obstacle"][:, 3::READING_SIZE].sum(axis=1).max() > 3
    np.testing.assert_array_equal(fast.times, systems.times)
    for key, values in systems.log.items():
        np.testing.assert_array_equal(fast.log[key], values, err_msg=key)


def test_every_count_is_flown_by_one_compilation():
    """The compiled functions take the count from their arrays' lengths: a
    chain of 1, 5 or 8 readings calls the entries a chain of 3 compiled
    (numba's overloads, keyed by the arguments' types, stay as they were)."""
    scenario = dataclasses.replace(cluster(), engine="compiled")
    OneIntegratorFleet(with_count(scenario, 3), "mfi")
    functions = (
        compiled.compiled(fleet).fleet_chain,
        compiled.compiled(fleet).fleet_modes,
        compiled.compiled(escape).fleet_memories,
    )
    before = [list(f.overloads) for f in functions]
    for count in (1, 5, 8):
        chain = OneIntegratorFleet(with_count(scenario, count), "mfi").chain
        assert chain.GetInputPort("scene").size() == signal_size(count)
    assert [list(f.overloads) for f in functions] == before


def test_the_fleet_chain_of_five_readings_is_each_vehicles_diagram():
    """Four vehicles beside a sphere, each seeing more than 3 things: the
    compiled chain's rows (the system one integrator flies) are what each
    vehicle's own diagram of 5 readings logs at that instant."""
    scene, states = crowded_fleet()
    scene = with_count(dataclasses.replace(scene, fleet_integration="one"))
    modes = [fields.MODE_CRUISE] * 3 + [fields.MODE_PD]
    want, scene_readings = single_vehicle_rows(scene, states, modes)
    chain = OneIntegratorFleet(scene, "mfi").chain
    context = chain.CreateDefaultContext()
    chain.GetInputPort("states").FixValue(context, states.ravel())
    chain.GetInputPort("scene").FixValue(context, scene_readings.ravel())
    n, memory = len(states), escape.memory_size(COUNT)
    # The escape memories as the diagrams' default ones (zeros).
    context.SetDiscreteState(np.concatenate((modes, np.zeros(n * memory))))
    rows = chain.GetOutputPort("rows").Eval(context).reshape(n, -1)
    assert rows.shape == want.shape
    np.testing.assert_allclose(rows, want, rtol=1e-12, atol=1e-12)
    seen = want[:, fleet.row_slices(COUNT)["obstacle"]][:, 3::READING_SIZE]
    assert (seen.sum(axis=1) > 3).all()


def test_a_fleet_of_five_readings_on_one_integrator_flies_as_separate():
    """Three vehicles through CLUSTER in lanes 2 m apart: one integrator
    against separate integration, both of 5 readings, within
    tests/test_one_integrator.py's bounds (measured: separations within
    1 mm, paths within 2 mm, convergence within 0.08 s; flown with 3
    readings, a path differs by 1.6 m)."""
    scene = cluster(lanes=(2.0, -2.0))
    apart = simulate(scene)
    together = simulate(dataclasses.replace(scene, fleet_integration="one"))
    assert together.metrics["outcome"] == apart.metrics["outcome"] == "success"
    assert max(map(most_within_reach, [together, *together.others])) > 3
    assert together.metrics["min_separation"] == pytest.approx(
        apart.metrics["min_separation"], abs=0.03
    )
    vehicles = zip(apart.metrics["vehicles"], together.metrics["vehicles"], strict=True)
    for a, b in vehicles:
        assert b["path_length"] == pytest.approx(a["path_length"], abs=0.02)
        assert b["convergence_time"] == pytest.approx(a["convergence_time"], abs=0.3)
