"""Input robustness: `load_scenario` on random and mutated YAML only ever
returns a Scenario or raises ScenarioError with a one-line message naming
the file, never another exception (hypothesis, bounded in time)."""

import os
import string
import tempfile

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mfi_drake.config.faults import Faults
from mfi_drake.config.scenario import Scenario, ScenarioError
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

SHIPPED = sorted(f for f in os.listdir(SCENARIOS) if f.endswith(".yaml"))
FUZZ = settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)

# Values and lines worth trying in place of what a scenario holds.
VALUES = [
    "",
    "~",
    "null",
    "true",
    "-1",
    "0",
    "-0.0",
    "1e-320",
    "1e400",
    "-.inf",
    ".nan",
    "123456789012345678901234567890",
    "'text'",
    "[]",
    "{}",
    "[1, 2]",
    "[1, 2, 3, 4]",
    "[.nan, 0, 0]",
    "[[1], [2], [3]]",
    "{_tag: [1]}",
    "{_tag: Sphere}",
    "!Sphere {radius: -1}",
    "!Sphere 3",
    "!Box [1, 2, 3]",
    "!Foo {x: 1}",
    "!Convex {file: meshes}",
    "!Convex {file: /dev/null}",
    "!Convex {file: scenario.yaml}",
    "!Convex {file: meshes/wedge.obj, scale: 1e300}",
    "!DepthCamera {}",
    "!SphereSensor {radius: 1e308}",
    "&a 1",
    "*a",
    "*undefined",
    "!!python/object:os.system 'true'",
    "!!binary AAAA",
    "!!set {a, b}",
    "{? [1, 2] : 3}",
    "[" * 400 + "]" * 400,
    "{a: " * 400 + "1" + "}" * 400,
    '"\\ud800"',
    "\t1",
]
LINES = [
    "faults: {dropout_prob: 2}",
    "faults: {sensor_latency: 1e9}",
    "faults: {weak_rotor: 1e3}",
    "faults: {seed: 99999999999999999999999999}",
    "faults: {sample_rate: 1e-300, sensor_latency: 1}",
    "unknown: 1",
    "navigator: {r_b: 5}",
    "navigator: {tilt_compensation: 1}",
    "simulator: {integration_scheme: foo}",
    "simulator: {accuracy: -1, max_step_size: .nan}",
    "apf: {attraction: {k_att: 0}}",
    "gf: {rho_0: 9}",
    "vehicle: [pelican]",
    "  - shape: !Sphere {radius: 1e-300}",
    "    position: [1e300, -1e300, 0]",
    "<<: *a",
    "<<: {name: merged}",
    "---",
    "...",
    "%YAML 1.1",
    "- 1",
    "? complex",
    "name: &n x\ngoal: *n",
]


@pytest.fixture(scope="module")
def workdir():
    """A directory holding the files under test, beside the shipped meshes."""
    with tempfile.TemporaryDirectory() as d:
        os.symlink(os.path.join(SCENARIOS, "meshes"), os.path.join(d, "meshes"))
        yield d


def check_loads_or_fails_cleanly(directory: str, text: str | bytes) -> None:
    path = os.path.join(directory, "scenario.yaml")
    with open(path, "wb") as f:
        f.write(text if isinstance(text, bytes) else text.encode("utf-8", "replace"))
    try:
        scenario = load_scenario(path)
    except ScenarioError as e:
        message = str(e)
        assert message.startswith(path) and "\n" not in message, message
    else:
        assert isinstance(scenario, Scenario) and isinstance(scenario.faults, Faults)


def mutate_lines(
    draw, lines: list[str], values: list[str], inserts: list[str], chars: str, cuts: str
) -> str:
    """`lines` with 1–3 line, token or character mutations: a YAML value,
    a token (the line split at spaces and at each of `cuts`) replaced by
    one of `values`, a line deleted, duplicated or one of `inserts` put
    before it, a character replaced by one of `chars`."""
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(lines) - 1))
        kind = draw(
            st.sampled_from(["value", "token", "delete", "duplicate", "insert", "char"])
        )
        line = lines[i]
        if kind == "value" and ":" in line:
            lines[i] = line.split(":", 1)[0] + ": " + draw(st.sampled_from(values))
        elif kind == "token":
            for cut in cuts:
                line = line.replace(cut, f" {cut} ")
            tokens = line.split(" ")
            j = draw(st.integers(0, len(tokens) - 1))
            tokens[j] = draw(st.sampled_from(values))
            lines[i] = " ".join(tokens)
        elif kind == "delete":
            del lines[i]
        elif kind == "duplicate":
            lines.insert(i, line)
        elif kind == "insert":
            lines.insert(i, draw(st.sampled_from(inserts)))
        elif line:
            j = draw(st.integers(0, len(line)))
            lines[i] = line[:j] + draw(st.sampled_from(chars)) + line[j + 1 :]
        if not lines:
            lines = [""]
    return "\n".join(lines) + "\n"


@st.composite
def mutated(draw):
    """A shipped scenario with 1–3 line, token or byte mutations."""
    name = draw(st.sampled_from(SHIPPED))
    with open(os.path.join(SCENARIOS, name)) as f:
        lines = f.read().splitlines()
    chars = ":-[]{}!&*#|>'\"\t ,0123456789.eE+x\x00\u00e9"
    return mutate_lines(draw, lines, VALUES, LINES, chars, ",]")


FIELD_NAMES = [
    "name",
    "start",
    "goal",
    "duration",
    "vehicle",
    "sensor",
    "obstacles",
    "navigator",
    "apf",
    "gf",
    "faults",
    "simulator",
    "goal_tolerance",
    "shape",
    "position",
    "radius",
    "size",
    "dropout_prob",
    "sensor_noise_std",
    "weak_rotor",
    "seed",
]
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(string.printable, max_size=8),
)
documents = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.dictionaries(
            st.one_of(st.sampled_from(FIELD_NAMES), st.text(max_size=5)),
            inner,
            max_size=5,
        ),
    ),
    max_leaves=20,
)


@FUZZ
@given(mutated())
def test_mutated_shipped_scenarios_load_or_fail_cleanly(workdir, text):
    check_loads_or_fails_cleanly(workdir, text)


@FUZZ
@given(documents)
def test_random_yaml_documents_load_or_fail_cleanly(workdir, document):
    check_loads_or_fails_cleanly(workdir, yaml.safe_dump(document))


@FUZZ
@given(st.binary(max_size=200))
def test_random_bytes_load_or_fail_cleanly(workdir, data):
    check_loads_or_fails_cleanly(workdir, data)


@pytest.mark.parametrize(
    "text",
    [
        "name: " + "[" * 2000 + "]" * 2000,  # was RecursionError
        "sensor: {_tag: [1]}",  # was TypeError: unhashable type
        "? '\\n'\n: 1\n",  # was a two-line message
    ],
)
def test_inputs_that_once_crashed_the_loader_fail_cleanly(workdir, text):
    path = os.path.join(workdir, "scenario.yaml")
    with open(path, "w") as f:
        f.write(text)
    with pytest.raises(ScenarioError) as e:
        load_scenario(path)
    assert "\n" not in str(e.value)


def test_a_missing_file_and_a_directory_fail_cleanly(workdir):
    for path, words in (
        (os.path.join(workdir, "absent.yaml"), "no such file"),
        (workdir, "is a directory, not a YAML file"),
    ):
        with pytest.raises(ScenarioError, match=words):
            load_scenario(path)
