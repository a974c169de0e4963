"""The saved HTML animation, rendered by a real headless browser: the scene
(obstacles, ground, every vehicle and its path) is drawn and framed by the
camera the page opens with, not an empty canvas. Needs Chromium from the OS
packages (apt-get install chromium); skipped, with the reason, without it."""

import os
import shutil
import subprocess

import numpy as np
import pytest
from matplotlib.image import imread
from pydrake.geometry import Meshcat, MeshcatParams

from mfi_drake.app.animation import frame_scene, scene_box, write_animation
from mfi_drake.files import write_text
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="Chromium not installed (apt-get install chromium)"
)
SIZE = (640, 480)
WANDERER = """obstacles:
  - shape: !Sphere {radius: 0.5}
    position: [0.0, 6.0, 2.0]
    motion: {amplitude: [2.0, 0.0, 0.5], angular_frequency: [0.5, 0.0, 0.3]}
"""


def screenshot(html: str, png: str) -> np.ndarray:
    """The page as Chromium draws it (WebGL in software), RGB in [0, 1]."""
    subprocess.run(
        [
            CHROMIUM,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--hide-scrollbars",
            f"--window-size={SIZE[0]},{SIZE[1]}",
            "--virtual-time-budget=10000",
            f"--screenshot={png}",
            f"file://{os.path.abspath(html)}",
        ],
        capture_output=True,
        timeout=120,
        check=True,
    )
    return imread(png)[:, :, :3]


def test_the_saved_animation_draws_the_scene_in_a_browser(tmp_path):
    # Four vehicles over a ground, and a sphere wandering past.
    scenario = load_scenario(
        os.path.join(SCENARIOS, "swarm_circle.yaml"),
        [("--set", "duration: 10"), ("--set", WANDERER)],
    )
    flight = simulate(scenario)
    page = str(tmp_path / "flight.html")
    write_animation(scenario, [flight], page)
    # The same page with nothing in it, seen by the same camera.
    empty = Meshcat(MeshcatParams(host="localhost"))
    frame_scene(empty, *scene_box(scenario, [flight]))
    control = str(tmp_path / "empty.html")
    write_text(control, empty.StaticHtml())

    drawn = screenshot(page, str(tmp_path / "flight.png"))
    blank = screenshot(control, str(tmp_path / "empty.png"))
    assert drawn.shape[:2] == (SIZE[1], SIZE[0])
    # WebGL drew the control's grid and background: not an empty canvas.
    assert len(np.unique(blank.reshape(-1, 3), axis=0)) > 20
    scene = np.abs(drawn - blank).max(axis=2) > 0.1
    assert scene.mean() > 0.05, f"only {scene.mean():.3%} of the pixels show the scene"
    # Framed: the scene is about the middle and inside the picture.
    rows, cols = np.nonzero(scene)
    assert abs(rows.mean() / SIZE[1] - 0.5) < 0.2
    assert abs(cols.mean() / SIZE[0] - 0.5) < 0.2
    # The method's colour (MFI's tab:blue paths and vehicles) is on screen.
    bluish = [image[:, :, 2] - image[:, :, 0] > 0.25 for image in (drawn, blank)]
    blue = bluish[0] & ~bluish[1]
    assert blue.sum() > 50
