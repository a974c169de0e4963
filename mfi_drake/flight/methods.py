"""The registry of navigation methods: MFI, the paper's baselines, and any
user's own navigation field. Every command, study, figure and animation
reads methods from here; a new built-in method is one entry of `METHODS`,
another name of one an entry of `ALIASES` (`resolve_method` reads both).

A method is the two systems of `systems.navigation` that turn the state and
the obstacle reading into F_n: a navigator and a goal attraction, each made
for a `NavigationConfig` (`navigation_config(scenario)` for a scenario's)
and a vehicle. The §V chain (attitude PD, mixer) is the same for every
method.

A user's field is a plain function `field(position, velocity,
obstacle_points, goal) -> force` (see `UserFieldNavigator`), named on the
command line as MODULE:NAME or passed to `simulate` as a callable.
"""

import importlib
import inspect
import math
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from pydrake.systems.framework import LeafSystem

from mfi_drake.config.navigation import NavigationConfig
from mfi_drake.config.scenario import SphereSensor
from mfi_drake.config.vehicle_gains import for_vehicle
from mfi_drake.config.vehicles import Vehicle
from mfi_drake.systems.escape import EscapeNavigator
from mfi_drake.systems.navigation import (
    ApfNavigator,
    GfNavigator,
    GoalAttractionSelector,
    MfiNavigator,
    PotentialGoalAttraction,
)
from mfi_drake.systems.user_field import PassThroughGoal, UserFieldNavigator


class MethodError(ValueError):
    """A method that cannot be flown: an unknown name, or a MODULE:NAME spec
    that cannot be imported, names nothing or names no function."""


@dataclass(frozen=True)
class Gain:
    """A free gain of a method, as `mfi-drake tune` searches it: the scenario
    field `path` (e.g. "navigator.c"), drawn in [low, high], log-uniformly
    if `log`. With `fraction_of`, the value is that fraction of another
    gain's (e.g. r_b as a fraction of r_l, which it must stay below)."""

    path: str
    low: float
    high: float
    log: bool = True
    fraction_of: str | None = None
    default: float | None = None  # where the scenario does not hold it


@dataclass(frozen=True)
class Method:
    name: str  # as the run JSON, the sweep records and the CLI name it
    label: str  # in figures and tables
    colour: str  # a matplotlib colour
    # The navigator system and the goal attraction, for a config and vehicle.
    navigator: Callable[[NavigationConfig, Vehicle], LeafSystem]
    goal_attraction: Callable[[NavigationConfig, Vehicle], LeafSystem]
    # The field holding its gains, a Scenario's and a NavigationConfig's.
    parameters: str | None = None
    gains: tuple[Gain, ...] = ()  # its documented free gains, for `tune`
    # Flown by compare, reproduce, sweep and tune when no --methods is given
    # (`DEFAULT_METHODS`): the paper's comparison and every published table.
    in_defaults: bool = True


def _mfi_gains(key: str) -> tuple[Gain, ...]:
    """MFI's free gains: eq 12–13's c and r_l, eq 15's c⊥ and r_b (< r_l),
    eq 17's K_ω. The cruise speed v_d stays 1 m/s for every method."""
    return (
        Gain(f"{key}.c", 0.5, 16.0),
        Gain(f"{key}.r_l", 0.3, 2.5),
        Gain(f"{key}.c_perp", 0.02, 1.0),
        Gain(f"{key}.r_b", 0.2, 0.9, log=False, fraction_of=f"{key}.r_l"),
        Gain(f"{key}.K_omega", 0.25, 4.0),
    )


def _goal(config: NavigationConfig) -> np.ndarray:
    return np.asarray(config.goal, float)


def gains(config: NavigationConfig, key: str, vehicle: Vehicle):
    """The config's parameters `key` ("navigator", "apf", ...) for
    `vehicle` (`config.vehicle_gains`: as given for the shipped presets),
    on the time scale of its attitude loop (`navigator`'s)."""
    return for_vehicle(getattr(config, key), vehicle, config.navigator)


def mfi_navigator(config: NavigationConfig, vehicle: Vehicle) -> "MfiNavigator":
    """MFI's memoryless navigator, eq 11–15 at the config's `navigator` gains."""
    return MfiNavigator(
        gains(config, "navigator", vehicle),
        _goal(config),
        vehicle.collision_radius,
        config.sensor.readings,
    )


def escape_off(config: NavigationConfig) -> str | None:
    """Why MFI flies `config` without the escape rule's memory, or None where
    it flies with it. The memory remembers static surfaces (hit points, the
    followed surface, a door's jambs): among moving obstacles there is no
    static scene to tell from the readings, nor in a fleet whose cameras
    render the other vehicles into the scene's depth images. With depth
    cameras the rule follows surfaces beside and below the vehicle that no
    camera may see (a held-out field's contact, a room's floor): only where
    the config asks (`escape.cameras`). Elsewhere MFI flies memoryless,
    as `mfi-memoryless` does (docs/nonconvex.md)."""
    if config.moving_obstacles:
        return "obstacles move"
    if not isinstance(config.sensor, SphereSensor):
        if config.other_vehicles:
            return "a fleet with cameras"
        if not config.escape.cameras:
            return "cameras (escape.cameras: false)"
    return None


def escape_navigator(
    config: NavigationConfig, vehicle: Vehicle
) -> "EscapeNavigator | MfiNavigator":
    """MFI's navigator: MFI with the escape rule and its memory
    (`EscapeNavigator`), memoryless where `escape_off` says. In a fleet its
    memory reads the static scene's readings (`OtherVehicleReadings`'
    "scene") and its field every reading with the relative velocity where
    that is on."""
    if escape_off(config):
        return mfi_navigator(config, vehicle)
    fleet = config.other_vehicles > 0
    relative = config.relative_velocity
    return EscapeNavigator(
        gains(config, "navigator", vehicle),
        _goal(config),
        vehicle.collision_radius,
        vehicle.mass,
        gains(config, "escape", vehicle),
        None if config.ground is None else config.ground.height,
        scene=fleet,
        relative=relative if fleet and relative.enabled else None,
        readings=config.sensor.readings,
    )


def _mfi_goal(key: str) -> Callable[[NavigationConfig, Vehicle], LeafSystem]:
    """Eq 16–21's goal attraction of MFI at the config's `key` gains."""
    return lambda c, vehicle: GoalAttractionSelector(
        gains(c, key, vehicle), _goal(c), mass=vehicle.mass
    )


def _obstacle_navigator(kind: Callable, key: str) -> Callable:
    """The navigator `kind` (MfiNavigator, ApfNavigator, GfNavigator) at the
    config's `key` gains."""
    return lambda c, vehicle: kind(
        gains(c, key, vehicle), _goal(c), vehicle.collision_radius, c.sensor.readings
    )


def _potential_goal(key: str) -> Callable[[NavigationConfig, Vehicle], LeafSystem]:
    """A baseline's goal attraction, the gradient of its potential."""
    return lambda c, vehicle: PotentialGoalAttraction(
        gains(c, key, vehicle).attraction, _goal(c)
    )


METHODS: dict[str, Method] = {
    # The default MFI: the escape rule and its memory in non-convex worlds
    # (docs/nonconvex.md); in convex worlds its corner brake is all that acts.
    "mfi": Method(
        name="mfi",
        label="MFI",
        colour="tab:blue",
        navigator=escape_navigator,
        goal_attraction=_mfi_goal("navigator"),
        parameters="navigator",
        gains=_mfi_gains("navigator"),
    ),
    "mfi-paper": Method(
        name="mfi-paper",
        label="MFI (paper)",
        colour="tab:cyan",
        navigator=_obstacle_navigator(MfiNavigator, "mfi_paper"),
        goal_attraction=_mfi_goal("mfi_paper"),
        parameters="mfi_paper",
        gains=_mfi_gains("mfi_paper"),
    ),
    "apf": Method(
        name="apf",
        label="APF",
        colour="tab:red",
        navigator=_obstacle_navigator(ApfNavigator, "apf"),
        goal_attraction=_potential_goal("apf"),
        parameters="apf",
        # Khatib's η and ρ₀, and the attraction's stiffness (v_max stays 1 m/s).
        gains=(
            Gain("apf.eta", 0.002, 0.5),
            Gain("apf.rho_0", 0.3, 2.5),
            Gain("apf.attraction.k_att", 0.5, 4.0),
        ),
    ),
    "gf": Method(
        name="gf",
        label="GF",
        colour="tab:green",
        navigator=_obstacle_navigator(GfNavigator, "gf"),
        goal_attraction=_potential_goal("gf"),
        parameters="gf",
        # The gyroscopic gain and shell, the repulsion inside its safety shell
        # (ρ₀ < r_d), and the attraction's stiffness (v_max stays 1 m/s). k_g
        # and η reach down far: a first tuning put both at their old floors.
        gains=(
            Gain("gf.k_g", 0.1, 64.0),
            Gain("gf.r_d", 0.3, 2.0),
            Gain("gf.eta", 0.0005, 0.2),
            Gain("gf.rho_0", 0.1, 0.9, log=False, fraction_of="gf.r_d"),
            Gain("gf.attraction.k_att", 0.5, 4.0),
        ),
    ),
    # MFI without the escape rule: the default MFI before non-convex worlds
    # (the same flights to the bit), the field `analyze` linearises.
    "mfi-memoryless": Method(
        name="mfi-memoryless",
        label="MFI (memoryless)",
        colour="tab:gray",
        navigator=mfi_navigator,
        goal_attraction=_mfi_goal("navigator"),
        parameters="navigator",
        gains=_mfi_gains("navigator"),
        in_defaults=False,
    ),
}
# Other names of a method, kept for scripts and records: "mfi-nc", MFI with
# the escape rule while it was a method of its own. A flight asked for by
# an alias is the method's, under the name it was asked for.
ALIASES: dict[str, str] = {"mfi-nc": "mfi"}
# Every name a method may be asked for by, as the CLI lists them.
METHOD_NAMES: tuple[str, ...] = (*METHODS, *ALIASES)
# The methods flown where none is named.
DEFAULT_METHODS = tuple(name for name, m in METHODS.items() if m.in_defaults)

# Colours of user methods, taken in turn by a stable hash of their name.
USER_COLOURS = ("tab:purple", "tab:orange", "tab:brown", "tab:pink", "tab:olive")


def appearance(name: str) -> tuple[str, str]:
    """(label, colour) of a method named in a result, without importing a
    user's module: a user method's label is the NAME of its MODULE:NAME."""
    if name in METHOD_NAMES:
        method = METHODS[ALIASES.get(name, name)]
        return method.label, method.colour
    return name.rsplit(":", 1)[-1], USER_COLOURS[sum(name.encode()) % len(USER_COLOURS)]


def user_method(field: Callable, name: str) -> Method:
    """A method that flies the user's navigation field `field`. Its free
    gains are what `field.gains` declares, {name: (low, high)}: the scenario's
    `field_gains` are passed to it as keyword arguments. Raises MethodError,
    before anything flies, where `field` cannot be called as the contract
    says, declared gains included."""
    label, colour = appearance(name)
    declared = getattr(field, "gains", {}) or {}
    _check_signature(field, name, declared)
    return Method(
        name=name,
        label=label,
        colour=colour,
        navigator=lambda c, _: UserFieldNavigator(
            field, name, _goal(c), c.field_gains, c.sensor.readings
        ),
        goal_attraction=lambda *_: PassThroughGoal(),
        parameters="field_gains",
        gains=tuple(
            Gain(f"field_gains.{key}", float(low), float(high), default=default)
            for key, (low, high) in declared.items()
            for default in [_keyword_default(field, key, low, high)]
        ),
    )


def _check_signature(field: Callable, name: str, declared: dict) -> None:
    try:
        signature = inspect.signature(field)
    except (TypeError, ValueError):  # no signature to read (some builtins)
        return
    try:  # partial: a required gain may come from the scenario's field_gains
        signature.bind_partial(0, 0, 0, 0, **dict.fromkeys(declared, 0.0))
    except TypeError as e:
        with_gains = f" and its gains {sorted(declared)}" if declared else ""
        raise MethodError(
            f"{name!r}: cannot be called as field(position, velocity, "
            f"obstacle_points, goal){with_gains}: {e}"
        ) from None


def _keyword_default(field: Callable, key: str, low: float, high: float) -> float:
    """The default of `field`'s keyword argument `key`, or the geometric
    middle of its range where it has none."""
    try:
        default = inspect.signature(field).parameters[key].default
    except (KeyError, TypeError, ValueError):
        default = None
    if isinstance(default, int | float) and not isinstance(default, bool):
        return float(default)
    return math.sqrt(float(low) * float(high))


def import_field(spec: str) -> Callable:
    """The function NAME of MODULE, for spec "MODULE:NAME", imported with
    the current directory first on the import path (as `python -m` has it)
    and PYTHONPATH after it. Raises MethodError naming the spec."""
    module_name, _, attribute = spec.partition(":")
    if not module_name or not attribute:
        raise MethodError(
            f"{spec!r}: must be one of {sorted(METHOD_NAMES)} or MODULE:NAME"
        )
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())
    try:
        module = importlib.import_module(module_name)
    except Exception as e:  # ImportError, or anything the module raises
        message = " ".join(str(e).split())
        raise MethodError(
            f"{spec!r}: cannot import {module_name!r} ({type(e).__name__}: {message})"
        ) from None
    field = module
    for part in attribute.split("."):
        if not hasattr(field, part):
            raise MethodError(f"{spec!r}: {module_name!r} has no {attribute!r}")
        field = getattr(field, part)
    if not callable(field):
        raise MethodError(f"{spec!r}: {attribute!r} is not callable")
    return field


def resolve_method(method: "str | Callable | Method") -> Method:
    """The registry entry of `method`: a name of METHODS (or ALIASES), a "MODULE:NAME"
    spec of a user's field, a callable field, or a Method itself."""
    if isinstance(method, Method):
        return method
    if isinstance(method, str):
        if method in METHODS:
            return METHODS[method]
        if method in ALIASES:
            return replace(METHODS[ALIASES[method]], name=method)
        return user_method(import_field(method), method)
    if callable(method):
        module = getattr(method, "__module__", None) or "<unknown>"
        name = getattr(method, "__qualname__", None) or type(method).__name__
        return user_method(method, f"{module}:{name}")
    raise MethodError(f"{method!r}: not a method name, MODULE:NAME or a function")
