"""The scenario fields of a dynamic scene (docs/dynamic.md): an obstacle's
`motion:`, the `ground:`, `other_vehicles:` flown at once, and how a
navigator sees moving obstacles (`relative_velocity:`). `config.scenario`
holds them and checks their values."""

from dataclasses import dataclass, field


def _zeros() -> list[float]:
    return [0.0, 0.0, 0.0]


@dataclass
class Motion:
    """An obstacle's position at time t is, per component, position +
    velocity·t + amplitude·sin(angular_frequency·t + phase); its
    orientation is fixed. Every key defaults to zeros."""

    velocity: list[float] = field(default_factory=_zeros)  # m/s
    amplitude: list[float] = field(default_factory=_zeros)  # m
    angular_frequency: list[float] = field(default_factory=_zeros)  # rad/s, ≥ 0
    phase: list[float] = field(default_factory=_zeros)  # rad


MOTION_KEYS = ("velocity", "amplitude", "angular_frequency", "phase")


def moves(motion: Motion | None) -> bool:
    """Whether an obstacle with this `motion:` ever leaves its position."""
    return motion is not None and any(
        x != 0.0 for x in [*motion.velocity, *motion.amplitude]
    )


@dataclass
class Ground:
    """An infinite horizontal plane at z = height, below which nothing flies."""

    height: float = 0.0  # m


@dataclass
class OtherVehicle:
    """A further vehicle flown at once, by the same method, with the same
    vehicle preset and sensor as the scenario's own."""

    start: list[float] = field(default_factory=lambda: [0.0, 0.0, 1.5])  # m
    goal: list[float] = field(default_factory=list)  # m; required: no default


@dataclass
class RelativeVelocity:
    """How a navigator sees moving obstacles and other vehicles: each
    reading's obstacle velocity is estimated from successive readings
    (`systems.relative`) and the navigator is given, per reading, the
    vehicle's velocity relative to that obstacle. Used only in a dynamic
    scene (a moving obstacle or another vehicle); off, the navigator gets
    the vehicle's own velocity as in a static scene."""

    enabled: bool = True
    # Steer with the relative velocities, keep the pace of the own velocity:
    # the difference the relative velocities make is taken across v only,
    # and not at all at rest (`maths.motion.keep_own_pace`). False: the
    # relative fields as they are.
    own_pace: bool = True
    rate_hz: float = 20.0  # readings sampled per second (a camera: its frames)
    time_constant: float = 0.1  # s, of the first-order low pass on the estimate
    gate: float = 0.3  # m, farthest a closest point may move between samples
    # The rule of the road among vehicles, in degrees: each vehicle's
    # velocity relative to another vehicle is turned this far to the right
    # (about e_z) before that vehicle's field term is evaluated, so every
    # vehicle swerves right of every other, and vehicles meeting in a crowd
    # circle it the same way (docs/fleets.md). 0: none.
    # Obstacles are seen as they are. Sphere sensors only: a camera cannot
    # tell a vehicle from an obstacle.
    keep_right: float = 60.0
