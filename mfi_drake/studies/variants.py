"""A sweep's variants: the names its records are keyed by (a motion, goals
near a surface, overrides, faults: `variant_name`) and the layering of
overrides and faults on a field (`layered`)."""

import hashlib
import os
import zlib
from dataclasses import fields, replace

from mfi_drake.config.faults import Faults
from mfi_drake.config.scenario import Scenario
from mfi_drake.config.scenario_yaml import layer


def goal_variant(gap: float | None) -> str:
    """A name for a sweep variant of goals near a surface ("" for none)."""
    return "" if gap is None else f"goal_clearance={gap:g}"


def motion_variant(share: float, speed: float) -> str:
    """A name for a sweep variant of moving obstacles ("" for none)."""
    return f"moving={share:g},obstacle_speed={speed:g}" if share > 0.0 else ""


def variant_name(
    overrides: list[tuple[str, str]] = (),
    faults: Faults | None = None,
    motion: str = "",
    goal: str = "",
) -> str:
    """The sweep variant of a motion (`motion_variant`), goals near a
    surface (`goal_variant`), overrides and faults: their names joined by
    commas, "" for none of them."""
    parts = [
        motion,
        goal,
        override_variant(overrides),
        fault_variant(faults) if faults is not None else "",
    ]
    return ",".join(part for part in parts if part)


def override_variant(overrides: list[tuple[str, str]]) -> str:
    """A name for a sweep variant of overrides: each --set text as given, each
    file as its name and a hash of its text (so a changed file is a new
    variant)."""
    parts = []
    for where, text in overrides:
        if where.startswith("--set"):
            parts.append(" ".join(text.split()))
        else:
            digest = hashlib.sha1(text.encode()).hexdigest()[:8]
            parts.append(f"{os.path.basename(where)}@{digest}")
    return ";".join(parts)


# --- faults flown on every field ------------------------------------------------
def fault_variant(faults: Faults) -> str:
    """A name for a sweep variant: the fields that differ from the defaults,
    as "field=value" joined by commas ("" for no faults)."""
    default = Faults()
    return ",".join(
        f"{f.name}={getattr(faults, f.name)!r}"
        for f in fields(faults)
        if getattr(faults, f.name) != getattr(default, f.name)
    )


def with_faults(scenario, faults: Faults):
    """A copy of `scenario` with `faults`, the seed offset by a CRC of the
    scenario's name so that the fields of a sweep draw independent noise."""
    seed = faults.seed + zlib.crc32(scenario.name.encode())
    return replace(scenario, faults=replace(faults, seed=seed))


def with_overrides(scenario: Scenario, overrides: list[tuple[str, str]]) -> Scenario:
    """`scenario` with each (where, YAML text) override layered on it, as
    `mfi-drake run --set/--override` layers them on a file."""
    for where, text in overrides:
        scenario = layer(scenario, text, where)
    return scenario


def layered(
    scenario: Scenario,
    overrides: list[tuple[str, str]] = (),
    faults: Faults | None = None,
) -> Scenario:
    """A field with a command's overrides layered on it, then its faults."""
    scenario = with_overrides(scenario, overrides)
    return scenario if faults is None else with_faults(scenario, faults)
