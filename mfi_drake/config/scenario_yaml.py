"""Scenario YAML: reading and writing the `Scenario` of `config.scenario`.

Scenarios layer as in Drake's hardware_sim: `parse_scenario` loads a file
onto the defaults, then each override (YAML text or an override file) onto
the result with `yaml_load_typed(..., defaults=...)`, every key and value
checked first against the dataclasses (`ScenarioError` naming the file,
the field and the value). `scenario_to_yaml` writes a whole scenario as
text the loader reads back; `scenario_from_yaml` reads it trusted.
"""

import dataclasses
import functools
import os
import types
import typing

import yaml
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from mfi_drake.config.checks import is_number
from mfi_drake.config.faults import Faults, fault_problems
from mfi_drake.config.scenario import (
    Scenario,
    ScenarioError,
    check_scenario,
    fail,
)
from mfi_drake.config.vehicle_model import VehicleModel, read_vehicle_model
from mfi_drake.config.vehicles import Vehicle, VehicleError


class _TaggedLoader(yaml.SafeLoader):
    """Reads `!Tag {..}` as {"_tag": "Tag", ...} for the schema check."""


def _construct_tagged(loader, suffix, node):
    if isinstance(node, yaml.MappingNode):
        data = loader.construct_mapping(node, deep=True)
    else:
        data = {"_value": loader.construct_object(node, deep=True)}
    return {"_tag": suffix, **data}


_TaggedLoader.add_multi_constructor("!", _construct_tagged)


def _check_schema(data, schema, where: str, name: str) -> None:
    """Checks raw YAML `data` against dataclass `schema` so that a wrong key or
    type is reported with its field path (yaml_load_typed's own messages do
    not always name the field). Drake's own config classes are left to
    yaml_load_typed."""
    shown = name or "scenario"
    if not dataclasses.is_dataclass(schema):
        _check_drake_keys(data, schema, where, name)
        return
    if not isinstance(data, dict):
        fail(where, shown, data, f"must be a mapping of {schema.__name__} fields")
    hints = typing.get_type_hints(schema)
    for key, value in data.items():
        if key == "_tag":
            continue
        field_name = f"{name}.{key}" if name else str(key)
        if key not in hints or key == "base_dir":
            fail(where, field_name, value, f"unknown field of {schema.__name__}")
        _check_value(value, hints[key], where, field_name)


def _check_drake_keys(data, schema, where: str, name: str) -> None:
    """A key that a Drake config class (e.g. a Transform) does not have is
    reported with its field path; its values are left to yaml_load_typed."""
    known = {f.name for f in getattr(schema, "__fields__", ())}
    if known and isinstance(data, dict):
        for key, value in data.items():
            if key != "_tag" and key not in known:
                reason = f"unknown field of {schema.__name__}"
                fail(where, f"{name}.{key}", value, reason)


def _check_value(value, hint, where: str, name: str) -> None:
    origin = typing.get_origin(hint)
    if hint is float:
        if not is_number(value):
            fail(where, name, value, "must be a number")
    elif hint is int:
        if not isinstance(value, int) or isinstance(value, bool):
            fail(where, name, value, "must be an integer")
    elif hint is bool:
        if not isinstance(value, bool):
            fail(where, name, value, "must be true or false")
    elif hint is str:
        if not isinstance(value, str):
            fail(where, name, value, "must be a string")
    elif origin is list:
        if not isinstance(value, list):
            fail(where, name, value, "must be a list")
        (item,) = typing.get_args(hint)
        for i, x in enumerate(value):
            _check_value(x, item, where, f"{name}[{i}]")
    elif origin in (types.UnionType, typing.Union):
        alternatives = typing.get_args(hint)
        if value is None and type(None) in alternatives:  # an optional block
            return
        options = {t.__name__: t for t in alternatives if t is not type(None)}
        if str in alternatives and isinstance(value, str):  # a vehicle's name
            return
        # Untagged is the first alternative, as Drake writes and reads it.
        first = next(iter(options))
        tag = value.get("_tag", first) if isinstance(value, dict) else None
        if not isinstance(tag, str) or tag not in options:
            fail(
                where,
                name,
                tag or value,
                f"must be tagged one of !{', !'.join(options)}",
            )
        _check_schema(value, options[tag], where, name)
    else:
        _check_schema(value, hint, where, name)


def _read_yaml(text: str, where: str):
    try:
        return yaml.load(text, Loader=_TaggedLoader)
    except (yaml.YAMLError, RecursionError) as e:
        message = " ".join(str(e).split())
        raise ScenarioError(f"{where}: not valid YAML: {message}") from None


def _read_file(path: str) -> str:
    if os.path.isdir(path):
        raise ScenarioError(f"{path}: is a directory, not a YAML file")
    if not os.path.isfile(path):
        raise ScenarioError(f"{path}: no such file")
    try:
        with open(path) as f:
            return f.read()
    except (UnicodeDecodeError, OSError) as e:
        message = " ".join(str(e).split())
        raise ScenarioError(f"{path}: not valid YAML: {message}") from None


def layer(scenario: Scenario, text: str, where: str) -> Scenario:
    """`scenario` with the YAML mapping `text` loaded on top of it (fields
    that `text` does not name keep their values); a `!VehicleModel` read
    into its `Vehicle` (its file relative to the scenario's directory).
    Not validated."""
    raw = _read_yaml(text, where)
    if raw is None:
        return scenario
    _check_schema(raw, Scenario, where, "")
    base_dir = scenario.base_dir
    layered = _typed(Scenario, text, where, defaults=scenario)
    layered.base_dir = base_dir
    try:  # a model file is flown as the record it reads
        layered.vehicle = _vehicle_record(layered.vehicle, base_dir)
    except VehicleError as e:
        raise ScenarioError(f"{where}: {e}") from None
    return layered


def _typed(schema, text: str, where: str, **defaults):
    """yaml_load_typed(schema, text), any error it raises as ScenarioError."""
    try:
        return yaml_load_typed(schema=schema, data=text, **defaults)
    except Exception as e:  # yaml_load_typed raises several types
        message = " ".join(str(e).split())
        raise ScenarioError(f"{where}: {message}") from None


def read_faults(text: str, where: str) -> Faults:
    """A `faults:` block given as YAML text (sweep --faults), checked like a
    scenario's: a bad key or value raises ScenarioError naming it."""
    raw = _read_yaml(text, where)
    if raw is None:  # '', '~', 'null': no faults
        return Faults()
    _check_schema(raw, Faults, where, "faults")
    faults = _typed(Faults, text, where)
    for name, value, reason in fault_problems(faults):
        fail(where, f"faults.{name}", value, reason)
    return faults


def read_override(path: str) -> tuple[str, str]:
    """(path, its text): an override file for `parse_scenario`."""
    return path, _read_file(path)


def layered_name(name: str, overrides: list[tuple[str, str]] = ()) -> str:
    """What an error names for scenario `name` with `overrides` layered on
    it: a bad value may come from any layer ("a.yaml with --set 'x: 1'")."""
    if not overrides:
        return name
    return f"{name} with {', '.join(where for where, _ in overrides)}"


def parse_scenario(path: str, overrides: list[tuple[str, str]] = ()) -> Scenario:
    """The scenario file `path` on the defaults, then each override (where,
    YAML text) on top, e.g. ("--set", "faults: {sensor_noise_std: 0.05}") or
    `read_override("tuned.yaml")`. Checked by `check_scenario`; relative mesh
    paths resolve against `path`'s directory."""
    scenario = Scenario(base_dir=os.path.dirname(os.path.abspath(path)))
    scenario = layer(scenario, _read_file(path), path)
    for where, text in overrides:
        scenario = layer(scenario, text, where)
    check_scenario(scenario, layered_name(path, overrides))
    return scenario


def _vehicle_record(vehicle, base_dir: str):
    """A !VehicleModel read into its Vehicle, a !Vehicle with its inertia a
    tuple (as `Vehicle` holds it), a preset's name as it is."""
    if isinstance(vehicle, VehicleModel):
        return read_vehicle_model(vehicle, base_dir)
    return dataclasses.replace(vehicle) if isinstance(vehicle, Vehicle) else vehicle


@functools.cache
def _file_schema() -> type:
    """Scenario's fields as a YAML file holds them: all but base_dir, which
    says where a file was read from (the loader sets it, and refuses it in
    a file)."""
    kept = [f for f in dataclasses.fields(Scenario) if f.name != "base_dir"]
    return dataclasses.make_dataclass("Scenario", [(f.name, f.type) for f in kept])


def scenario_to_yaml(scenario: Scenario) -> str:
    """The whole scenario, every default included (a worker's defaults need
    not be the client's), as YAML text that `load_scenario` reads back:
    what travels to a sweep worker (Drake's SimulatorConfig does not
    pickle). Not base_dir: a receiver resolving relative mesh files is
    given it apart (`scenario_from_yaml`)."""
    return yaml_dump_typed(scenario, schema=_file_schema())


def scenario_from_yaml(text: str, base_dir: str = "") -> Scenario:
    """The inverse of `scenario_to_yaml` (trusted text: not validated), its
    relative mesh files resolved against `base_dir`."""
    defaults = Scenario(base_dir=base_dir)
    scenario = yaml_load_typed(schema=Scenario, data=text, defaults=defaults)
    scenario.vehicle = _vehicle_record(scenario.vehicle, base_dir)
    return scenario
