"""mfi_drake: magnetic-field-inspired (MFI) reactive navigation for
quadcopters, as a Drake block diagram.

The public API, imported on first use (importing the package loads nothing
else):

- `load_scenario(path, overrides=())`: a validated `Scenario`;
- `simulate(scenario, method="mfi")`: a `Flight` with its `metrics`;
  `method` is a name of `METHODS`, "MODULE:NAME" of a user's field, or the
  field function itself.

The layers, imports only downward (tests/test_layers.py): maths → config →
world → systems → flight → studies → app.
"""

import importlib

_API = {
    "load_scenario": "mfi_drake.world.validation",
    "Scenario": "mfi_drake.config.scenario",
    "ScenarioError": "mfi_drake.config.scenario",
    "simulate": "mfi_drake.flight.simulation",
    "Flight": "mfi_drake.flight.result",
    "METHODS": "mfi_drake.flight.methods",
}

__all__ = sorted(_API)


def __getattr__(name: str):
    if name in _API:
        return getattr(importlib.import_module(_API[name]), name)
    raise AttributeError(f"module 'mfi_drake' has no attribute {name!r}")
