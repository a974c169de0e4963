"""The scenario fields of a world file (docs/usage.md, "World files"):
where the file is placed (`world_pose:`), where its `model://` includes
are searched (`model_paths:`), and the warning a world file gives when it
holds what the scenario does not read. `config.scenario` holds them and
calls `world_problems`."""

from dataclasses import dataclass, field


class ScenarioWarning(UserWarning):
    """A scenario that can be flown but may not be what was meant."""


@dataclass
class WorldPose:
    """Where a world file's frame is in the scenario's frame: the file's
    point p lands at position + R(rpy_deg)·p (obstacles' own poses use the
    same fields)."""

    position: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # m
    rpy_deg: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # deg


def world_problems(
    world: str, pose: WorldPose, model_paths: list[str]
) -> list[tuple[str, object, str]]:
    """(field, value, reason) for each problem of the world-file fields that
    needs no file: a pose with no world file to place (a loaded scenario
    has none: loading resets it), an empty search folder."""
    problems = []
    for i, folder in enumerate(model_paths):
        if not folder:
            problems.append((f"model_paths[{i}]", folder, "must name a folder"))
    if pose != WorldPose() and not world:
        problems.append(("world_pose", pose, "places a `world:` file; there is none"))
    return problems
