"""The search of `mfi-drake tune` (steps 2 and 3 of `studies.tune`'s
protocol): the unit cube of a method's free gains, the points tried in it,
the override that sets them, and the lexicographic objective."""

import json
import math
from dataclasses import dataclass, field

import numpy as np

from mfi_drake.config.scenario import Scenario
from mfi_drake.flight.methods import Gain


# --- the search space ---------------------------------------------------------------
def gain_values(gains: tuple[Gain, ...], unit: np.ndarray) -> dict[str, float]:
    """The gains at point `unit` of the unit cube (one coordinate per gain)."""
    values: dict[str, float] = {}
    for gain, u in zip(gains, unit, strict=True):
        if gain.log:
            value = gain.low * (gain.high / gain.low) ** float(u)
        else:
            value = gain.low + (gain.high - gain.low) * float(u)
        if gain.fraction_of is not None:
            value *= values[gain.fraction_of]
        values[gain.path] = float(value)
    return values


def unit_point(gains: tuple[Gain, ...], values: dict[str, float]) -> np.ndarray:
    """The inverse of `gain_values`, clipped to the unit cube."""
    out = []
    for gain in gains:
        value = values[gain.path]
        if gain.fraction_of is not None:
            value /= values[gain.fraction_of]
        if gain.log:
            u = math.log(value / gain.low) / math.log(gain.high / gain.low)
        else:
            u = (value - gain.low) / (gain.high - gain.low)
        out.append(min(1.0, max(0.0, u)))
    return np.array(out)


def latin_hypercube(rng: np.random.Generator, count: int, dims: int) -> np.ndarray:
    """`count` points of the unit cube, one in each of `count` equal strata
    of every coordinate, the strata paired at random."""
    strata = np.array([rng.permutation(count) for _ in range(dims)]).T
    return (strata + rng.random((count, dims))) / count


def override_text(values: dict[str, float]) -> str:
    """The YAML override that sets `values` (dotted scenario paths)."""
    tree: dict = {}
    for path, value in values.items():
        *parents, leaf = path.split(".")
        node = tree
        for key in parents:
            node = node.setdefault(key, {})
        node[leaf] = value
    return json.dumps(tree)  # JSON is YAML


def current_values(scenario: Scenario, gains: tuple[Gain, ...]) -> dict[str, float]:
    """The gains' values in `scenario` (the method's defaults)."""
    values = {}
    for gain in gains:
        node = scenario
        for key in gain.path.split("."):
            if isinstance(node, dict):  # a user field's keyword arguments
                node = node.get(key, gain.default)
            else:
                node = getattr(node, key)
        values[gain.path] = float(node)
    return values


# --- scoring ------------------------------------------------------------------------
def score(records: list[dict]) -> tuple:
    """The objective of a candidate's flights, larger is better (see the
    module docstring)."""
    ok = [r for r in records if r["outcome"] == "success"]
    ratios = [r["path_ratio"] for r in ok if r.get("path_ratio") is not None]
    times = [r["convergence_time"] for r in ok]
    # Path ratios within 0.001 (and times within 0.01 s) count as equal:
    # finer differences are integration noise, not a better method.
    return (
        len(ok),
        -sum(r["outcome"] == "collision" for r in records),
        -round(float(np.mean(ratios)), 3) if ratios else -math.inf,
        -round(float(np.mean(times)), 2) if times else -math.inf,
    )


@dataclass
class Candidate:
    index: int
    values: dict[str, float]
    records: list[dict] = field(default_factory=list)

    def summary(self) -> dict:
        s = score(self.records)
        return {
            "candidate": self.index,
            "gains": self.values,
            "flights": len(self.records),
            "successes": s[0],
            "collisions": -s[1],
            "mean_path_ratio": -s[2] if math.isfinite(s[2]) else None,
            "mean_convergence_time": -s[3] if math.isfinite(s[3]) else None,
        }
