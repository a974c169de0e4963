"""A flight's log on disk: a .npz archive, written atomically."""

import json

import numpy as np

from mfi_drake.files import atomic_path
from mfi_drake.flight.result import Flight


def write_flight_log(path: str, flight: Flight) -> None:
    """The whole log: `times` and one array per logged signal, plus the
    metrics as a JSON string under `metrics`. A fleet's other vehicles,
    k = 1, 2, … in the order of `other_vehicles`, each logged at its own
    integrator's steps: `vehicle<k>_times` and `vehicle<k>_<signal>`."""
    others = {}
    for k, other in enumerate(flight.others, 1):
        others[f"vehicle{k}_times"] = other.times
        others |= {f"vehicle{k}_{name}": a for name, a in other.log.items()}
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(
            f,
            times=flight.times,
            metrics=np.array(json.dumps(flight.metrics)),
            **flight.log,
            **others,
        )
