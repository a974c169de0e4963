"""mfi_drake: magnetic-field-inspired (MFI) reactive navigation for
quadcopters, as a Drake block diagram.

The public API, imported on first use (importing the package loads nothing
else):

- `load_scenario(path, overrides=())`: a validated `Scenario`;
- `simulate(scenario, method="mfi")`: a `Flight` with its `metrics`;
  `method` is a name of `METHODS`, "MODULE:NAME" of a user's field, or the
  field function itself;
- `NavigationStep(goal, method="mfi", ...)`: the navigation chain one
  call at a time, `step(state, points) -> StepOutput`, for a flight stack.

The builder API, MFI in a user's own Drake diagram:

- `add_navigation(builder, plant, scene_graph, goal, ...)` or
  `add_navigation(builder, plant, scene_graph, config=NavigationConfig(...))`:
  the sensor, navigator, goal attraction, attitude PD, mixer and logger
  around the user's QuadrotorPlant or MultibodyPlant; `NavigationHandles`;
  `NavigationConfig` from YAML with `read_navigation_config(text)`, from a
  `Scenario` with `navigation_config(scenario)`;
- its pieces `add_sensor`, `add_controller` (`Controller`; it takes a
  `NavigationConfig`), `add_logger`, `LOG_LAYOUT`;
- `apply_simulator_config(config, simulator)` with
  `default_simulator_config()`: what a plain Simulator needs beyond
  Drake's ApplySimulatorConfig (eq 21's witnesses read the context's
  accuracy);
- `BuilderError`: a bad argument, named;
- any quadrotor: `Vehicle`, `VehicleModel` and `as_vehicle(vehicle)`, what
  every entry point's `vehicle` takes (docs/vehicles.md);
- the MultibodyPlant vehicle: `vehicle_model_path(name)` (its SDFormat
  file), `add_vehicle_model(plant, vehicle)`, `add_propellers`,
  `add_vehicle_state` (`MultibodyVehicleState`), `place_vehicle`.

The closed loop linearised: `build_analysis_diagram(scenario)` (eq 21's
mode fixed, nothing seen), `hover_state(goal)`, `linearize_closed_loop`
(Drake's Linearize), `finite_difference_jacobian`, `hover_modes`.

Every name is documented in docs/api.md; examples/ runs them.

The layers, imports only downward (tests/test_layers.py): maths → config →
world → systems → flight → adapters → studies → app.
"""

import importlib

# The release (pyproject.toml reads it here); a sweep refuses a cluster whose
# scheduler or workers have another (`studies.cluster.check_cluster`).
__version__ = "0.1.0"

_API = {
    "load_scenario": "mfi_drake.world.validation",
    "Scenario": "mfi_drake.config.scenario",
    "ScenarioError": "mfi_drake.config.scenario",
    "simulate": "mfi_drake.flight.simulation",
    "Flight": "mfi_drake.flight.result",
    "METHODS": "mfi_drake.flight.methods",
    "DEFAULT_METHODS": "mfi_drake.flight.methods",
    "NavigationStep": "mfi_drake.flight.step",
    "StepOutput": "mfi_drake.flight.step",
    "add_navigation": "mfi_drake.flight.builder",
    "NavigationConfig": "mfi_drake.config.navigation",
    "read_navigation_config": "mfi_drake.config.navigation",
    "navigation_config": "mfi_drake.config.navigation",
    "NavigationHandles": "mfi_drake.flight.builder",
    "BuilderError": "mfi_drake.flight.builder",
    "apply_simulator_config": "mfi_drake.flight.builder",
    "default_simulator_config": "mfi_drake.config.scenario",
    "add_sensor": "mfi_drake.flight.chain",
    "add_controller": "mfi_drake.flight.chain",
    "Controller": "mfi_drake.flight.chain",
    "add_logger": "mfi_drake.flight.chain",
    "LOG_LAYOUT": "mfi_drake.flight.chain",
    "SphereSensor": "mfi_drake.config.sensors",
    "DepthCamera": "mfi_drake.config.sensors",
    "DepthCameraRig": "mfi_drake.config.sensors",
    "NavigatorParams": "mfi_drake.config.parameters",
    "Faults": "mfi_drake.config.faults",
    "add_vehicle_model": "mfi_drake.systems.multibody",
    "add_vehicle_state": "mfi_drake.systems.multibody",
    "add_propellers": "mfi_drake.systems.multibody",
    "place_vehicle": "mfi_drake.systems.multibody",
    "MultibodyVehicleState": "mfi_drake.systems.multibody",
    "vehicle_model_path": "mfi_drake.config.vehicles",
    "Vehicle": "mfi_drake.config.vehicles",
    "as_vehicle": "mfi_drake.config.vehicles",
    "VehicleModel": "mfi_drake.config.vehicle_model",
    "build_analysis_diagram": "mfi_drake.flight.analysis_diagram",
    "hover_state": "mfi_drake.flight.analysis_diagram",
    "linearize_closed_loop": "mfi_drake.studies.analysis.linearization",
    "finite_difference_jacobian": "mfi_drake.studies.analysis.linearization",
    "hover_modes": "mfi_drake.studies.analysis.linearization",
}

__all__ = sorted(_API)


def __getattr__(name: str):
    if name in _API:
        return getattr(importlib.import_module(_API[name]), name)
    raise AttributeError(f"module 'mfi_drake' has no attribute {name!r}")
