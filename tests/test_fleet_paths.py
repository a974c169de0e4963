"""benchmarks/fleet_paths.py's fleets as one Drake diagram (docs/fleets.md,
"One fleet path?"): each vehicle's sensor reads the others' spheres in the
shared SceneGraph and not its own, and the diagram of `add_navigation`'s
Python chains flies what its twin of compiled chains flies."""

import os
from dataclasses import replace

import numpy as np

from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.world.fleets import with_vehicles
from mfi_drake.world.validation import load_scenario

from .conftest import ROOT, load_benchmark


def test_one_drake_diagram_sees_the_others_and_flies_its_compiled_twin():
    paths = load_benchmark("fleet_paths")
    corridor = load_scenario(os.path.join(ROOT, "scenarios", "swarm_corridor.yaml"))
    # Nothing but the two vehicles, 2.5 m apart, closing head-on.
    empty = replace(corridor, obstacles=[], ground=None, duration=1.0)
    ends = [([3.0, -0.1, 2.0], [10.0, -0.1, 2.0]), ([5.5, 0.1, 2.0], [0.0, 0.1, 2.0])]
    fleet = with_vehicles(empty, ends)
    python = paths.fly_drake_diagram(fleet, compiled=False)
    compiled = paths.fly_drake_diagram(fleet, compiled=True)
    radius = as_vehicle(fleet.vehicle).collision_radius
    for flight in (python, compiled):
        vehicles = [flight, *flight.others]
        assert [f.times[0] for f in vehicles] == [0.0, 0.0]
        for k, own in enumerate(vehicles):
            # At the start: the other's sphere, its closest point in closed
            # form (|d| − ρ) d/|d|; the vehicle's own sphere is never read.
            d = np.subtract(ends[1 - k][0], ends[k][0])
            closest = (np.linalg.norm(d) - radius) * d / np.linalg.norm(d)
            reading = own.log["obstacle"][0]
            np.testing.assert_allclose(reading[:3], closest, atol=1e-9)
            assert reading[3] == 1.0 and not reading[4:].any()
    # The same flight: the compiled chain is the Python chain's maths.
    assert python.integrator_steps == compiled.integrator_steps
    twins = zip([python, *python.others], [compiled, *compiled.others], strict=True)
    for a, b in twins:
        np.testing.assert_allclose(a.positions, b.positions, atol=1e-9)
        assert np.linalg.norm(a.positions[-1] - a.positions[0]) > 0.1  # it flew
