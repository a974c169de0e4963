"""Shared fixtures: paths to the shipped scenarios and a YAML writer."""

import os
import textwrap

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENARIOS = os.path.join(ROOT, "scenarios")


@pytest.fixture
def write_yaml(tmp_path):
    """Writes a (dedented) YAML text to a file in tmp_path; returns its path."""

    def write(text: str, name: str = "scenario.yaml") -> str:
        path = tmp_path / name
        path.write_text(textwrap.dedent(text))
        return str(path)

    return write
