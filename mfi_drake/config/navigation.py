"""`NavigationConfig`: what `flight.builder.add_navigation` adds to a Drake
diagram, as one typed record, in the style of Drake's
`Apply*Config(config, builder)`: the goal, the vehicle, the method, the
sensor, every method's gains, the escape rule, the faults, and what the
navigator must know of the scene it flies in (other vehicles, moving
obstacles, the ground).

Its fields are named as a scenario's (docs/usage.md), so a `Method`'s
`parameters` ("navigator", "apf", ...) name a field of either, and it loads
from YAML with Drake's `yaml_load_typed` as a scenario does
(`read_navigation_config`). `navigation_config` takes a Scenario's.
"""

import dataclasses
import math
from dataclasses import dataclass, field

from mfi_drake.config.dynamic import Ground, RelativeVelocity, moves
from mfi_drake.config.faults import Faults
from mfi_drake.config.parameters import (
    ApfParams,
    GfParams,
    NavigatorParams,
    paper_form,
)
from mfi_drake.config.scenario import (
    Scenario,
    ScenarioError,
    Sensor,
    SphereSensor,
    check_navigation_fields,
    fail,
)
from mfi_drake.config.scenario_yaml import (
    _check_schema,
    _read_yaml,
    _typed,
    _vehicle_record,
)
from mfi_drake.config.vehicle_model import VehicleModel
from mfi_drake.config.vehicles import Vehicle, VehicleError
from mfi_drake.maths.escape import EscapeParams


@dataclass
class NavigationConfig:
    """Everything `add_navigation` needs besides the diagram's systems; the
    YAML keys are these fields (a scenario's of the same names)."""

    goal: list[float] = field(default_factory=list)  # m; required: no default
    vehicle: str | Vehicle | VehicleModel = "drake_default"  # docs/vehicles.md
    # A name of `flight.methods.METHODS` (or an alias), or a user's field's
    # MODULE:NAME.
    method: str = "mfi"
    sensor: Sensor = field(default_factory=SphereSensor)
    navigator: NavigatorParams = field(default_factory=NavigatorParams)
    # The gains of the other methods, as a scenario's (docs/parameters.md).
    mfi_paper: NavigatorParams = field(
        default_factory=lambda: paper_form(NavigatorParams())
    )
    apf: ApfParams = field(default_factory=ApfParams)
    gf: GfParams = field(default_factory=GfParams)
    escape: EscapeParams = field(default_factory=EscapeParams)  # MFI's escape rule
    field_gains: dict[str, float] = field(default_factory=dict)  # a user's field's
    faults: Faults = field(default_factory=Faults)  # all off by default
    relative_velocity: RelativeVelocity = field(default_factory=RelativeVelocity)
    ground: Ground | None = None  # the escape rule's floor; none: no ground
    # How many other vehicles of a fleet come in through the diagram's
    # exported input "other_vehicles" (`flight.chain.add_sensor`).
    other_vehicles: int = 0
    # Whether obstacles move (docs/dynamic.md): the navigator reads each
    # one's relative velocity, and MFI flies without the escape rule's
    # memory (`flight.methods.escape_off`). `add_navigation` also finds it
    # in the SceneGraph (`flight.scene.scene_moves`).
    moving_obstacles: bool = False


def check_navigation(config: NavigationConfig, where: str) -> None:
    """Raises ScenarioError for the first bad field of `config`, in one line
    naming `where`, the field and its value. The method's name is checked
    where it is resolved (`flight.methods.resolve_method`)."""
    if not isinstance(config, NavigationConfig):
        fail(where, "config", config, "must be a NavigationConfig")
    for f in dataclasses.fields(NavigationConfig):
        value, kind = getattr(config, f.name), f.type
        if dataclasses.is_dataclass(kind) and not isinstance(value, kind):
            fail(where, f.name, value, f"must be a {kind.__name__}")
    goal = config.goal
    if not (
        isinstance(goal, list) and len(goal) == 3 and all(_finite(x) for x in goal)
    ):
        fail(where, "goal", goal, "must be 3 finite numbers [x, y, z] (m)")
    if not isinstance(config.method, str) or not config.method:
        fail(where, "method", config.method, "must be a method's name or MODULE:NAME")
    check_navigation_fields(config, where)
    count = config.other_vehicles
    if not isinstance(count, int) or isinstance(count, bool) or count < 0:
        fail(where, "other_vehicles", count, "must be a whole number ≥ 0")
    if count and config.faults != Faults():
        fail(where, "other_vehicles", count, "are flown without faults")
    if not isinstance(config.moving_obstacles, bool):
        fail(
            where, "moving_obstacles", config.moving_obstacles, "must be true or false"
        )


def _finite(x) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def read_navigation_config(
    text: str, where: str = "NavigationConfig", base_dir: str = ""
) -> NavigationConfig:
    """The NavigationConfig of the YAML mapping `text`, loaded onto the
    defaults with Drake's `yaml_load_typed` and checked: a bad key or
    value raises ScenarioError in one line naming `where` and the field.
    A `!VehicleModel` is read into its Vehicle, its file relative to
    `base_dir`."""
    raw = _read_yaml(text, where)
    _check_schema({} if raw is None else raw, NavigationConfig, where, "")
    config = _typed(NavigationConfig, text or "{}", where)
    try:
        config.vehicle = _vehicle_record(config.vehicle, base_dir)
    except VehicleError as e:
        raise ScenarioError(f"{where}: {e}") from None
    check_navigation(config, where)
    return config


def navigation_config(scenario: Scenario, method: str = "mfi") -> NavigationConfig:
    """The navigation fields of `scenario`, flown by `method`: what
    `flight.diagram.build_diagram` gives `add_navigation`. Its obstacles
    move where one has a motion (`world.motion.obstacles_move`)."""
    own = ("goal", "method", "other_vehicles", "moving_obstacles")
    return NavigationConfig(
        **{
            f.name: getattr(scenario, f.name)
            for f in dataclasses.fields(NavigationConfig)
            if f.name not in own
        },
        goal=list(scenario.goal),
        method=method,
        other_vehicles=len(scenario.other_vehicles),
        moving_obstacles=any(moves(o.motion) for o in scenario.obstacles),
    )
