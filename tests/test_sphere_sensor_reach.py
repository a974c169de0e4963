"""The sphere sensor queries SceneGraph with a reach shortened from its last
reading (`SphereSensor._calc`); every reading it logs is the one the full
radius gives."""

import numpy as np
from pydrake.geometry import SceneGraph

from mfi_drake.flight.simulation import simulate
from mfi_drake.world import generator
from mfi_drake.world.obstacles import nearest_obstacles, register_obstacles


def test_every_logged_reading_is_the_full_radius_reading():
    scenario = generator.random_field(3, 0, 0.2)
    flight = simulate(scenario, until_settled=True)
    scene_graph = SceneGraph()
    register_obstacles(scene_graph, scenario)
    query = scene_graph.get_query_output_port().Eval(scene_graph.CreateDefaultContext())
    readings = flight.log["obstacle"]
    assert (readings[:, 11] > 0.5).mean() > 0.3  # three obstacles seen, often
    for p, logged in zip(flight.positions, readings, strict=True):
        full = nearest_obstacles(query, p, scenario.sensor.radius)
        np.testing.assert_array_equal(logged, full)
