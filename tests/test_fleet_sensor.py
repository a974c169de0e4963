"""`FleetSceneSensor`, every vehicle's sphere-sensor reading of a static
scene in one system (a fleet on one integrator), against each vehicle's
own reading: `nearest_obstacles` within the full radius (no memo, no
shortened reach) and a `SphereSensor` a vehicle."""

import dataclasses

import numpy as np
from pydrake.geometry import SceneGraph
from pydrake.systems.framework import DiagramBuilder, EventStatus

from mfi_drake.config import scenario as sc
from mfi_drake.flight.fleet import OneIntegratorFleet
from mfi_drake.flight.one_integrator import one_integrator_monitor
from mfi_drake.maths.layout import OBSTACLE_SIGNAL_SIZE, STATE_SIZE
from mfi_drake.systems.sensors import FleetSceneSensor, SphereSensor
from mfi_drake.world import generator
from mfi_drake.world.fleets import random_pairs
from mfi_drake.world.obstacles import (
    nearest_obstacles,
    obstacle_distances,
    register_obstacles,
)

RADIUS = 3.0


def scene_with_ground() -> sc.Scenario:
    """A random field of 40 obstacles over a ground: spheres, boxes and
    cylinders, and a half space."""
    field = generator.random_field(3, 0, 0.2)
    return dataclasses.replace(field, ground=sc.Ground(height=-0.5))


def fleet_path(n: int) -> list[np.ndarray]:
    """States (n, 12) along a path: every vehicle moving 5 cm a state, some
    states repeated (as the integrator repeats the logger's), one jump; the
    last but one vehicle coming in from beside the field (fewer than three
    readings, then more), the last far above it (nothing within r_s)."""
    rng = np.random.default_rng(11)
    start = rng.uniform([0.5, -2.0, 0.0], [9.5, 2.0, 2.0], (n, 3))
    start[-1] = [5.0, 0.0, 50.0]
    heading = rng.normal(size=(n, 3))
    heading /= np.linalg.norm(heading, axis=1)[:, None]
    start[-2], heading[-2] = [5.0, 6.0, 1.0], [0.0, -1.0, 0.0]
    path = []
    for i in range(40):
        p = start + 0.05 * i * heading
        if i >= 30:
            p = p + [0.0, 0.0, 0.7]  # a jump: farther than the last reach
        x = np.zeros((n, STATE_SIZE))
        x[:, 0:3] = p
        path += [x] * (2 if i % 3 == 0 else 1)
    return path


def test_each_vehicles_reading_is_its_own_sphere_sensors():
    scenario, n = scene_with_ground(), 5
    builder = DiagramBuilder()
    scene_graph = builder.AddSystem(SceneGraph())
    register_obstacles(scene_graph, scenario)
    fleet = builder.AddSystem(FleetSceneSensor(RADIUS, n))
    alone = [builder.AddSystem(SphereSensor(RADIUS)) for _ in range(n)]
    query = scene_graph.get_query_output_port()
    for system in [fleet, *alone]:
        builder.Connect(query, system.GetInputPort("query"))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    port = fleet.GetOutputPort("scene")
    seen = []
    for states in fleet_path(n):
        fleet_context = fleet.GetMyMutableContextFromRoot(context)
        fleet.GetInputPort("states").FixValue(fleet_context, states.ravel())
        got = port.Eval(fleet_context).reshape(n, OBSTACLE_SIGNAL_SIZE)
        oracle = query.Eval(scene_graph.GetMyContextFromRoot(context))
        for k, system in enumerate(alone):
            own = system.GetMyMutableContextFromRoot(context)
            system.GetInputPort("state").FixValue(own, states[k])
            reading = system.GetOutputPort("obstacle").Eval(own)
            full = nearest_obstacles(oracle, states[k, 0:3], RADIUS)
            np.testing.assert_array_equal(got[k], full)
            np.testing.assert_array_equal(got[k], reading)
        seen.append(got[:, 3::4].sum(axis=1))
    seen = np.array(seen)
    assert (seen[:, :-1] == 3).mean() > 0.5  # the memo's shortened reach, often
    assert (seen[:, :-1] == 3).any(axis=0).all() and (seen[:, :-1] < 3).any()
    assert (seen[:, -1] == 0).all()  # nothing within r_s of the last vehicle


def test_a_fleet_on_one_integrator_stops_where_a_vehicle_reads_contact():
    scene = random_pairs(generator.random_field(0, 0, 0.1), 2, 0, 0)
    scene = dataclasses.replace(scene, fleet_integration="one")
    fleet = OneIntegratorFleet(scene, "mfi")
    monitor = one_integrator_monitor(fleet, False, True)
    context = fleet.diagram.CreateDefaultContext()
    for plant, flown in zip(fleet.plants, fleet.flown, strict=True):
        x = np.zeros(STATE_SIZE)
        x[0:3] = flown.start
        plant.GetMyMutableContextFromRoot(context).SetContinuousState(x)
    kinds = [monitor(context).severity()]
    # The second vehicle 0.1 m above the first obstacle's top, well within
    # its collision radius.
    above = np.array(scene.obstacles[0].position) + np.outer(
        np.linspace(0.0, 3.0, 601), [0.0, 0.0, 1.0]
    )
    gaps = np.array(obstacle_distances(scene, above))
    x[0:3] = above[np.argmax(gaps >= 0.1)]
    fleet.plants[1].GetMyMutableContextFromRoot(context).SetContinuousState(x)
    kinds.append(monitor(context).severity())
    assert kinds == [
        EventStatus.Severity.kSucceeded,
        EventStatus.Severity.kReachedTermination,
    ]
