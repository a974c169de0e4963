"""The checks every scenario field goes through: a `ScenarioError` whose
one line names the file, the field and the value (`fail`), and the checks
of a vector, a positive number and a number that the config modules
share."""

import math


class ScenarioError(ValueError):
    """A scenario that cannot be flown; the message is one line for the user."""


# --- obstacle shapes (the YAML tags !Box, !Sphere, ...) -----------------------
def fail(where: str, name: str, value, reason: str):
    if not name.isprintable():  # a YAML key may hold a line break
        name = repr(name)
    raise ScenarioError(f"{where}: {name} = {value!r}: {reason}")


def check_vector(where, name, value, positive=False):
    if not isinstance(value, list) or len(value) != 3:
        fail(where, name, value, "must be a list of 3 numbers")
    for x in value:
        if not isinstance(x, int | float) or not math.isfinite(x):
            fail(where, name, value, "must hold finite numbers")
        if positive and x <= 0:
            fail(where, name, value, "must be > 0")


def check_positive(where, name, value):
    if not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
        fail(where, name, value, "must be a finite number > 0")


def is_number(x) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)
