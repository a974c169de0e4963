"""The other vehicles of a fleet as one vehicle's diagram sees them
(docs/fleets.md).

Each vehicle of a fleet is flown by its own single-vehicle diagram and
Simulator (`flight.fleet_exchange.fly_fleet`); every 1/exchange_hz s the
vehicles exchange their positions and velocities, as real vehicles would by
radio. Between exchanges each vehicle places the others where the last
message puts them, moving on at the velocity it gave (a linear
extrapolation), as spheres of their collision radius:

- with the sphere sensor, `OtherVehicleReadings` adds them to the sensor's
  readings of the static scene, exactly as SceneGraph reads a sphere, and
  gives each reading's velocity along its normal (`obstacle_velocity`, as
  `systems.relative`'s estimate does, here known from the message);
- with cameras, `OtherVehicleSpheres` poses them in SceneGraph, where the
  cameras render them.

The message a vehicle receives (`message`): [t_k, the others' positions,
the others' velocities], the others in the fleet's order without it.
"""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    RenderLabel,
    SceneGraph,
)
from pydrake.geometry import Sphere as DrakeSphere
from pydrake.math import RigidTransform
from pydrake.systems.framework import LeafSystem

from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    POSITION,
    STATE_SIZE,
    reading_count,
    signal_size,
)
from mfi_drake.maths.motion import vehicle_readings
from mfi_drake.systems.last_result import LastResult
from mfi_drake.systems.sensors import VEHICLE_RGBA
from mfi_drake.world.obstacles import sensed


def message_size(count: int) -> int:
    return 1 + 6 * count


def message(t: float, positions, velocities, k: int) -> np.ndarray:
    """What vehicle k receives at the exchange at time t: t, then the
    positions and the velocities ((n, 3) each, the whole fleet's) of every
    vehicle but k, in the fleet's order."""
    others = [
        np.delete(np.asarray(a, float), k, axis=0).ravel()
        for a in (positions, velocities)
    ]
    return np.concatenate([[t], *others])


def extrapolated(received: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """(centres, velocities), (m, 3) each: the others at time t, moved on
    from the message's time at the message's velocities."""
    m = (len(received) - 1) // 6
    p = received[1 : 1 + 3 * m].reshape(m, 3)
    v = received[1 + 3 * m :].reshape(m, 3)
    return p + v * (t - received[0]), v


class OtherVehicleReadings(LeafSystem):
    """The sphere sensor's readings with the other vehicles added.

    .. pydrake_system::

        name: OtherVehicleReadings
        input_ports:
        - state
        - obstacle
        - other_vehicles
        output_ports:
        - obstacle
        - obstacle_velocity
        - vehicle_readings
        - scene

    "obstacle" (input): the sphere sensor's readings of the scene without
    the vehicles; "other_vehicles": the last `message`; "obstacle" (output):
    the `readings` nearest of those readings and of the others' spheres
    within `sensor_radius` (a sphere's closest point, as SceneGraph gives
    it: r_o = (|d| − ρ) d/|d|, d from the vehicle to the centre);
    "obstacle_velocity": per output reading, its vehicle's velocity along
    the reading's normal (`maths.motion.along_normal`), zero for the scene's;
    "vehicle_readings": per output reading, 1 where it is another vehicle
    (the relative navigator's rule of the road), else 0; "scene": the
    input "obstacle" as it is, the static scene alone (what MFI's memory
    reads in a fleet, `systems.escape`).
    """

    def __init__(
        self,
        count: int,
        radius: float,
        sensor_radius: float,
        readings: int = OBSTACLE_COUNT,
    ):
        super().__init__()
        signal = signal_size(readings)
        self._radius = float(radius)
        self._reach = float(sensor_radius)
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self._obstacle = self.DeclareVectorInputPort("obstacle", signal)
        self._message = self.DeclareVectorInputPort(
            "other_vehicles", message_size(count)
        )
        tickets = {p.ticket() for p in (self._state, self._obstacle, self._message)}
        tickets.add(self.time_ticket())
        self._last = LastResult()
        outputs = (
            ("obstacle", signal),
            ("obstacle_velocity", 3 * readings),
            ("vehicle_readings", readings),
        )
        for k, (name, size) in enumerate(outputs):
            self.DeclareVectorOutputPort(
                name,
                size,
                lambda context, out, k=k: out.SetFromVector(self._merged(context)[k]),
                prerequisites_of_calc=tickets,
            )
        self.DeclareVectorOutputPort(
            "scene",
            signal,
            lambda context, out: out.SetFromVector(self._obstacle.Eval(context)),
            prerequisites_of_calc={self._obstacle.ticket()},
        )

    def _merged(self, context) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(the readings, their velocities, the vehicles among them),
        computed once for the three ports."""
        p = self._state.Eval(context)[POSITION]
        scene = self._obstacle.Eval(context)
        received = self._message.Eval(context)
        t = context.get_time()
        key = (t, p.tobytes(), scene.tobytes(), received.tobytes())
        return self._last(key, merge, p, scene, received, t, self._radius, self._reach)


def merge(
    p, scene, received, t, radius, reach
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`OtherVehicleReadings`' outputs at position p and time t: the
    others where the message `received` puts them at t
    (`maths.motion.vehicle_readings`)."""
    centres, velocities = extrapolated(received, t)
    # The scene stands still for the rule of the road's readings (a moving
    # scene's velocities are the relative navigator's estimate).
    still = np.zeros(3 * reading_count(scene))
    return vehicle_readings(p, scene, still, centres, velocities, radius, reach)


class OtherVehicleSpheres(LeafSystem):
    """Poses the other vehicles' collision spheres in SceneGraph, where the
    last message puts them, for cameras to render.

    .. pydrake_system::

        name: OtherVehicleSpheres
        input_ports:
        - other_vehicles
        output_ports:
        - geometry_pose

    The spheres carry the proximity and the perception roles.
    """

    def __init__(self, scene_graph: SceneGraph, count: int, radius: float):
        super().__init__()
        self._source = scene_graph.RegisterSource("other_vehicles")
        self._frames = []
        for k in range(count):
            frame = scene_graph.RegisterFrame(
                self._source, GeometryFrame(f"other_vehicle_{k}")
            )
            sphere = GeometryInstance(
                RigidTransform(), DrakeSphere(radius), f"other_vehicle_{k}"
            )
            sensed(sphere, VEHICLE_RGBA, RenderLabel.kDontCare)
            scene_graph.RegisterGeometry(self._source, frame, sphere)
            self._frames.append(frame)
        self._message = self.DeclareVectorInputPort(
            "other_vehicles", message_size(count)
        )
        self.DeclareAbstractOutputPort(
            "geometry_pose",
            lambda: AbstractValue.Make(FramePoseVector()),
            self._calc,
            prerequisites_of_calc={self._message.ticket(), self.time_ticket()},
        )

    @property
    def source_id(self):
        return self._source

    def _calc(self, context, output):
        centres, _ = extrapolated(self._message.Eval(context), context.get_time())
        poses = output.get_mutable_value()
        for frame, c in zip(self._frames, centres, strict=True):
            poses.set_value(frame, RigidTransform(c))
