"""A flight's log on disk: a .npz archive, written atomically."""

import json

import numpy as np

from mfi_drake.files import atomic_path
from mfi_drake.flight.simulation import Flight


def write_flight_log(path: str, flight: Flight) -> None:
    """The whole log: `times` and one array per logged signal, plus the
    metrics as a JSON string under `metrics`."""
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(
            f,
            times=flight.times,
            metrics=np.array(json.dumps(flight.metrics)),
            **flight.log,
        )
