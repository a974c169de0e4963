"""The paper's sphere sensor (§III) over a point-cloud map."""

import numpy as np
from pydrake.systems.framework import LeafSystem

from mfi_drake.maths.layout import OBSTACLE_COUNT, POSITION, STATE_SIZE, signal_size
from mfi_drake.maths.point_maps import MapReader


class PointMapSensor(LeafSystem):
    """The sphere sensor of a point-cloud map: the map's points within r_s,
    grouped into obstacles as the depth camera's perception groups its
    samples, the closest point of each of the `readings` nearest
    (`maths.point_maps.map_readings`, read by a `MapReader`: the points
    near the vehicle only).

    .. pydrake_system::

        name: PointMapSensor
        input_ports:
        - state
        output_ports:
        - obstacle

    "state": the plant's 12-vector; "obstacle": `readings` readings
    [r_o, seen], nearest first (`maths.layout`). `points` (n, 3), world
    frame, are copied at construction.
    """

    def __init__(self, points, radius: float, readings: int = OBSTACLE_COUNT):
        super().__init__()
        self._read = MapReader(
            np.array(points, dtype=float).reshape(-1, 3), radius, readings
        )
        self._last = (None, None)  # (position bytes, reading): see _calc
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self.DeclareVectorOutputPort(
            "obstacle",
            signal_size(readings),
            self._calc,
            prerequisites_of_calc={self._state.ticket()},
        )

    def _calc(self, context, output):
        p = self._state.Eval(context)[POSITION]
        # The map is fixed, so the reading depends on p alone; the step's
        # first evaluation repeats the logger's.
        key = p.tobytes()
        if key != self._last[0]:
            self._last = (key, self._read(p))
        output.SetFromVector(self._last[1])
