"""The flight figures: a top view beside the 3-D view, and methods that stay
distinguishable where their paths lie on each other."""

import dataclasses
import os

import numpy as np
import pytest

from mfi_drake.app.figures import flights_figure, plot_flights
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS


@pytest.fixture(scope="module")
def wall_flights():
    """APF at the planar wall for 3 s, and the same flight again labelled GF:
    two methods whose paths coincide exactly."""
    scenario = load_scenario(
        os.path.join(SCENARIOS, "planar_wall.yaml"), [("--set", "duration: 3")]
    )
    apf = simulate(scenario, "apf")
    return scenario, [apf, dataclasses.replace(apf, method="gf")]


def top_view(fig):
    (ax,) = [ax for ax in fig.axes if ax.get_title() == "top view"]
    return ax


def test_the_top_view_draws_each_path_in_x_and_y(wall_flights):
    scenario, flights = wall_flights
    fig = flights_figure(scenario, flights)
    assert fig.axes[0].name == "3d"
    ax = top_view(fig)
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x [m]", "y [m]")
    paths = [line.get_xydata() for line in ax.get_lines()]
    for flight in flights:
        assert any(np.array_equal(p, flight.positions[:, :2]) for p in paths)
    # The wall's footprint (x in [3.9, 4.1], y in [−2, 2]) is drawn, and the
    # view holds it, the start and the goal, at equal scales.
    (footprint,) = ax.collections[:1]
    corners = np.vstack([path.vertices for path in footprint.get_paths()])
    np.testing.assert_allclose(corners.min(axis=0), [3.9, -2.0], atol=1e-9)
    np.testing.assert_allclose(corners.max(axis=0), [4.1, 2.0], atol=1e-9)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert x0 < 0.0 and x1 > 8.0 and x1 - x0 == pytest.approx(y1 - y0)


def test_methods_on_the_same_path_differ_in_style_and_marked_samples(wall_flights):
    scenario, flights = wall_flights
    fig = flights_figure(scenario, flights)
    for ax in (fig.axes[0], top_view(fig)):
        apf, gf = [
            line
            for line in ax.get_lines()
            if line.get_color() in ("#d62728", "#2ca02c", "tab:red", "tab:green")
        ]
        assert apf.get_linestyle() != gf.get_linestyle()
        assert apf.get_marker() != gf.get_marker()
        # Staggered: where the paths coincide, the markers do not.
        assert not set(apf.get_markevery()) & set(gf.get_markevery())
        assert len(apf.get_markevery()) >= 2
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels == ["APF (failed)", "GF (failed)", "start", "goal"]


def test_one_method_alone_is_drawn_without_markers(wall_flights, tmp_path):
    scenario, flights = wall_flights
    fig = flights_figure(scenario, flights[:1])
    assert all(line.get_marker() in ("None", None) for line in top_view(fig).lines)
    plot_flights(scenario, flights[:1], str(tmp_path / "one.png"))
    assert (tmp_path / "one.png").read_bytes().startswith(b"\x89PNG")


def test_every_obstacle_is_drawn_as_one_collection():
    """The still obstacles' triangles, all of them, in one collection a
    view (one artist each cost a 1,000-obstacle world's figure 40 s); the
    moving pole at its start and its end, in two more."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from mfi_drake.config import scenario as sc
    from mfi_drake.world.obstacles import obstacle_triangles

    scenario = load_scenario(os.path.join(SCENARIOS, "moving_crossing.yaml"))
    rng = np.random.default_rng(2)
    shapes = [sc.Box(size=[0.3, 0.4, 0.5]), sc.Cylinder(radius=0.2, length=1.0)]
    still = [
        sc.Obstacle(shape=shapes[k % 2], position=rng.uniform(-5, 5, 3).tolist())
        for k in range(120)
    ]
    scenario = dataclasses.replace(scenario, obstacles=[*scenario.obstacles, *still])
    fig = flights_figure(scenario, [])
    FigureCanvasAgg(fig).draw()  # projects the 3-D polygons
    pole = len(obstacle_triangles(scenario, scenario.obstacles[0], 0.0))
    expected = [
        sum(len(obstacle_triangles(scenario, o, 0.0)) for o in still),
        pole,
        pole,
    ]
    drawn3d = [c for c in fig.axes[0].collections if isinstance(c, Poly3DCollection)]
    assert [len(c.get_paths()) for c in drawn3d] == expected
    top = [c for c in top_view(fig).collections if type(c).__name__ == "PolyCollection"]
    assert [len(c.get_paths()) for c in top] == expected
