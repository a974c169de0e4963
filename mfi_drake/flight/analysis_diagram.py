"""`build_analysis_diagram`: the flight diagram without SceneGraph.

The same plant (`diagram.make_plant`), navigator, selector, attitude PD and
mixer, wired by `chain.connect_controller`, with the navigator's
"obstacle" input fed by a constant "nothing seen" source. Its selector has a
fixed mode (eq 21's PD or cruise), so the diagram has no discrete state and
Drake's `Linearize` converts it to AutoDiffXd as it is.
"""

from dataclasses import dataclass

import numpy as np
from pydrake.examples import QuadrotorPlant
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from mfi_drake.config.navigation import NavigationConfig
from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicle_gains import for_vehicle
from mfi_drake.config.vehicles import Vehicle, as_vehicle
from mfi_drake.flight.builder import add_rotor_path
from mfi_drake.flight.chain import connect_controller
from mfi_drake.flight.diagram import make_plant
from mfi_drake.maths import fields
from mfi_drake.maths.layout import OBSTACLE_SIGNAL_SIZE
from mfi_drake.systems.control import AttitudePD, RotorMixer
from mfi_drake.systems.navigation import GoalAttractionSelector, MfiNavigator


@dataclass
class AnalysisDiagram:
    diagram: Diagram
    plant: QuadrotorPlant
    vehicle: Vehicle
    params: NavigatorParams
    goal: np.ndarray

    def state(self, x: np.ndarray) -> np.ndarray:
        """The diagram's whole continuous state for the plant's 12-state x:
        the plant's come first, then the motors' lag (where the vehicle has
        one, `flight.builder.add_rotor_path`) at hover, its state 0."""
        size = self.diagram.CreateDefaultContext().num_continuous_states()
        return np.concatenate([x, np.zeros(size - len(x))])


def build_analysis_diagram(
    scenario: Scenario | NavigationConfig,
    mode: int = fields.MODE_PD,
    attitude_K: tuple[np.ndarray, np.ndarray] | None = None,
) -> AnalysisDiagram:
    """The MFI closed loop of `scenario` (or a NavigationConfig: its goal,
    vehicle and navigator gains) with eq 21's `mode` fixed and no obstacle
    seen; `attitude_K` = (K_Pθ, K_Dθ) overrides eq 25's gains."""
    vehicle = as_vehicle(scenario.vehicle)
    params = for_vehicle(scenario.navigator, vehicle)  # AttitudePD's own too
    goal = np.asarray(scenario.goal, float)
    K_P, K_D = attitude_K if attitude_K is not None else (None, None)
    builder = DiagramBuilder()
    plant = builder.AddNamedSystem("quadrotor", make_plant(vehicle))
    nothing_seen = builder.AddNamedSystem(
        "no_obstacle", ConstantVectorSource(np.zeros(OBSTACLE_SIGNAL_SIZE))
    )
    controller = [
        builder.AddNamedSystem(name, system)
        for name, system in (
            ("navigator", MfiNavigator(params, goal, vehicle.collision_radius)),
            ("selector", GoalAttractionSelector(params, goal, mode)),
            ("attitude_pd", AttitudePD(vehicle, scenario.navigator, K_P, K_D)),
            ("mixer", RotorMixer(vehicle)),
        )
    ]
    connect_controller(
        builder,
        plant.get_output_port(0),
        nothing_seen.get_output_port(0),
        *controller,
        add_rotor_path(builder, vehicle, plant.get_input_port(0), True),
    )
    diagram = builder.Build()
    diagram.set_name(f"mfi_drake analysis[{vehicle.name}, mode {mode}]")
    return AnalysisDiagram(diagram, plant, vehicle, params, goal)


def hover_state(position) -> np.ndarray:
    """At rest and level at `position`."""
    x = np.zeros(12)
    x[0:3] = position
    return x


def time_derivatives(diagram: Diagram, x: np.ndarray) -> np.ndarray:
    """ẋ of `diagram` at continuous state x (its other inputs at default)."""
    context = diagram.CreateDefaultContext()
    context.SetContinuousState(x)
    return diagram.EvalTimeDerivatives(context).CopyToVector()
