"""`sweep`'s engine (issue contract: sweeps default to `compiled` wherever
every method of the run flies on it): `studies.sweep.default_engine` on
the layers a command builds, and the records of a sweep naming the engine
that flew each flight."""

from functools import partial

import pytest

from mfi_drake.app.cli import main
from mfi_drake.config.faults import Faults
from mfi_drake.studies import records as record_store
from mfi_drake.studies.sweep import SINGLE, SweepConfig, default_engine, field_to_fly
from mfi_drake.studies.variants import layered

EVERY = ["mfi", "mfi-paper", "apf", "gf"]


def engine_of(methods, overrides=(), faults=None, world="random") -> str:
    """The engine the first field of a sweep of `methods` flies on, with
    the command's layers."""
    config = SweepConfig(n=1, seed=3, methods=methods, world=world)
    modify = partial(layered, overrides=list(overrides), faults=faults)
    chosen = default_engine(config, SINGLE, modify)
    return field_to_fly(config, SINGLE, chosen, config.flight_keys()[0]).engine


def test_compiled_where_every_method_flies_on_it():
    assert engine_of(EVERY) == "compiled"
    assert engine_of(["mfi"], world="cup") == "compiled"  # the escape rule
    assert engine_of(["mfi-memoryless"], world="cup") == "compiled"


@pytest.mark.parametrize(
    ("overrides", "faults", "engine"),
    [
        ([("--set", "engine: systems")], None, "systems"),  # a layer names it
        ([("--set", "engine: compiled")], None, "compiled"),
        ([("--set", "duration: 5")], None, "compiled"),  # a layer that does not
        ([], Faults(sensor_noise_std=0.05), "compiled"),  # a lone vehicle's faults
        ([("--set", "sensor: !DepthCamera {}")], None, "systems"),
    ],
)
def test_a_layer_or_what_it_asks_for_decides(overrides, faults, engine):
    assert engine_of(EVERY, overrides, faults) == engine


def test_the_records_name_the_engine_that_flew(tmp_path):
    """A sweep of MFI with and without memory flies on the compiled engine, one with
    `engine: systems` on the systems; each record says which."""
    for methods, engine in (("mfi,mfi-memoryless", "compiled"), ("mfi", "systems")):
        out = tmp_path / methods
        args = ["sweep", "--n", "1", "--seed", "3", "--methods", methods]
        args += ["--set", "duration: 3", "--workers", "1", "--out", str(out)]
        args += ["--set", f"engine: {engine}"] * (engine == "systems")
        assert main(args) == 0
        records = record_store.read_results(str(out / "results.jsonl"))
        assert {r["engine"] for r in records} == {engine}
        assert len(records) == len(methods.split(","))
