"""The diagram command and the command line's argument handling."""

import os
import shutil

import pytest

from mfi_drake.app.cli import main

from .conftest import SCENARIOS


@pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz `dot` not installed")
def test_diagram_command_draws_every_named_system(tmp_path):
    out = tmp_path / "d.svg"
    assert (
        main(
            ["diagram", os.path.join(SCENARIOS, "planar_wall.yaml"), "--out", str(out)]
        )
        == 0
    )
    svg = out.read_text()
    assert svg.lstrip().startswith("<?xml") and "</svg>" in svg
    for name in [
        "quadrotor",
        "sensor",
        "navigator",
        "selector",
        "attitude_pd",
        "mixer",
    ]:
        assert name in svg


def test_diagram_needs_an_svg_name(tmp_path, capsys):
    path = os.path.join(SCENARIOS, "planar_wall.yaml")
    assert main(["diagram", path, "--out", str(tmp_path / "d.png")]) == 2
    assert "--out" in capsys.readouterr().err
