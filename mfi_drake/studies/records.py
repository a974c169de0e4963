"""A sweep's record store: each flight's key (`FlightKey`), the outcomes a
record may hold, and DIR/results.jsonl, read whole (`read_results`, a
partial last line cut off) and appended one complete line at a time
(`append_record`, `ResultsFile`)."""

import json
import os
from typing import NamedTuple

from mfi_drake.flight.result import OUTCOMES as FLIGHT_OUTCOMES

RANDOM = "random"  # the world of the random fields (`generator.random_field`)


class FlightKey(NamedTuple):
    """What identifies a flight in results.jsonl."""

    variant: str
    sensor: str
    density: float | None  # None: a generated world, where density has no sense
    seed: int
    index: int
    method: str
    # RANDOM, or a class of `nonconvex.KINDS` (world `index` of that class).
    world: str = RANDOM

    @property
    def field(self) -> "FlightKey":
        """The field's part of the key (the method blanked)."""
        return self._replace(method="")


KEY_FIELDS = FlightKey._fields

OUTCOMES = (*FLIGHT_OUTCOMES, "error")  # error: the simulation raised


# --- results file ---------------------------------------------------------------
def record_key(record: dict) -> FlightKey:
    """A record's key; a record without a world is a random field's."""
    return FlightKey(*(record[k] for k in KEY_FIELDS[:-1]), record.get("world", RANDOM))


def key_record(key: FlightKey) -> dict:
    """A key's fields in its record: a random field's record leaves its
    world out, as records did before the generated worlds."""
    fields = key._asdict()
    if key.world == RANDOM:
        del fields["world"]
    return fields


def read_results(path: str) -> list[dict]:
    """The complete records in `path`; a trailing partial line (a kill in the
    middle of a write) is cut off the file."""
    if not os.path.exists(path):
        return []
    with open(path, "rb") as f:
        data = f.read()
    end = data.rfind(b"\n") + 1
    if end < len(data):
        os.truncate(path, end)
    return [json.loads(line) for line in data[:end].splitlines() if line.strip()]


def append_record(f, record: dict) -> None:
    """One complete line, on disk before this returns."""
    f.write(json.dumps(record, allow_nan=False) + "\n")
    f.flush()
    os.fsync(f.fileno())


class ResultsFile:
    """A records file appended one record at a time (`append_record`),
    created with its folder at the first record: a run refused before
    anything flies leaves no file behind. Closed on leaving a `with`."""

    def __init__(self, path: str):
        self.path, self._file = path, None

    def append(self, record: dict) -> None:
        if self._file is None:
            os.makedirs(os.path.dirname(os.path.abspath(self.path)), exist_ok=True)
            self._file = open(self.path, "a")  # noqa: SIM115 (closed on exit)
        append_record(self._file, record)

    def __enter__(self) -> "ResultsFile":
        return self

    def __exit__(self, *exc) -> None:
        if self._file is not None:
            self._file.close()
