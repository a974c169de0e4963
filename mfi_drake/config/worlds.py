"""The warning a world file gives when it holds what the scenario does not
read (a cloud's points with no return, ...)."""


class ScenarioWarning(UserWarning):
    """A scenario that can be flown but may not be what was meant."""
