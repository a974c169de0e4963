"""The saved HTML animation, rendered by a real headless browser: the scene
(obstacles, ground, every vehicle and its path) is drawn and framed by the
camera the page opens with, not an empty canvas; the page is titled with the
scenario, has a legend of the methods' colours and marks the goal. Needs
Chromium from the OS packages (apt-get install chromium); skipped, with the
reason, without it."""

import json
import os
import shutil
import subprocess
import tempfile

import numpy as np
import pytest
from matplotlib.colors import to_hex
from matplotlib.image import imread

from mfi_drake.app.animation import (
    frame_scene,
    legend_html,
    offline_meshcat,
    scene_box,
    titled_page,
    write_animation,
)
from mfi_drake.app.cli import main
from mfi_drake.files import write_text
from mfi_drake.flight.methods import appearance
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


def chromium(*args: str) -> str:
    """Headless Chromium, with a fresh profile and no network of its own,
    on `args`; returns what it printed on stdout."""
    with tempfile.TemporaryDirectory() as profile:
        done = subprocess.run(
            [
                CHROMIUM,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                f"--user-data-dir={profile}",
                "--use-angle=swiftshader",
                "--enable-unsafe-swiftshader",
                "--virtual-time-budget=10000",
                *args,
            ],
            capture_output=True,
            text=True,
            timeout=120,
            check=True,
        )
    return done.stdout


def screenshot(html: str, png: str) -> np.ndarray:
    """The page as Chromium draws it (WebGL in software), RGB in [0, 1]."""
    chromium(
        "--hide-scrollbars",
        f"--window-size={SIZE[0]},{SIZE[1]}",
        f"--screenshot={png}",
        f"file://{os.path.abspath(html)}",
    )
    return imread(png)[:, :, :3]


# Appended to a copy of the page: once Meshcat has drawn the scene, every
# object's name and world position (three.js frame: y up) into the DOM.
PROBE = """<script>
setTimeout(function () {
  var found = [];
  viewer.scene.traverse(function (o) {
    var p = o.getWorldPosition(new MeshCat.THREE.Vector3());
    found.push([o.name, p.x, p.y, p.z]);
  });
  var pre = document.createElement("pre");
  pre.id = "probe";
  pre.textContent = JSON.stringify(found);
  document.body.appendChild(pre);
}, 3000);
</script>"""


def rendered(html: str, probed: str) -> tuple[str, dict]:
    """(the DOM Chromium rendered from `html`, {object name: its world
    positions} of the Meshcat scene), via a copy at `probed` with PROBE."""
    with open(html) as f:
        page = f.read()
    write_text(probed, page.replace("</body>", PROBE + "</body>"))
    dom = chromium("--dump-dom", f"file://{os.path.abspath(probed)}")
    found = json.loads(dom.split('<pre id="probe">')[1].split("</pre>")[0])
    objects = {}
    for name, *position in found:
        objects.setdefault(name, []).append(position)
    return dom, objects


def test_the_saved_animation_draws_the_scene_in_a_browser(tmp_path):
    # Four vehicles over a ground, and a sphere wandering past.
    scenario = load_scenario(
        os.path.join(SCENARIOS, "swarm_circle.yaml"),
        [("--set", "duration: 10"), ("--set", WANDERER)],
    )
    flight = simulate(scenario)
    page = str(tmp_path / "flight.html")
    write_animation(scenario, [flight], page)
    # The same page with nothing in it, seen by the same camera, with the
    # same legend over it: what differs is the scene alone.
    empty = offline_meshcat()
    frame_scene(empty, *scene_box(scenario, [flight]))
    control = str(tmp_path / "empty.html")
    write_text(control, titled_page(empty.StaticHtml(), "empty", legend_html([flight])))

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


def test_the_page_is_titled_with_a_legend_and_the_goal_and_serves_nothing(
    tmp_path, capfd
):
    page = str(tmp_path / "compare.html")
    args = ["compare", os.path.join(SCENARIOS, "planar_wall.yaml")]
    args += ["--methods", "mfi,apf", "--set", "duration: 2", "--out", str(tmp_path)]
    # 2 s is too short to reach the goal: both time out, exit status 1.
    assert main([*args, "--html", page]) == 1
    printed = capfd.readouterr()
    assert "Meshcat" not in printed.out + printed.err
    assert "http://" not in printed.out + printed.err

    dom, objects = rendered(page, str(tmp_path / "probed.html"))
    assert "<title>planar_wall: MFI, APF (mfi-drake)</title>" in dom
    legend = dom.split('<div id="legend"')[1].split("</div></div>")[0]
    for method in ("mfi", "apf"):
        label, colour = appearance(method)
        assert f'{to_hex(colour)}"></span>{label} (failed)' in legend
    assert legend.endswith("goal")
    # The goal's ball is in the scene at the scenario's goal (Drake's z up
    # is three.js's y up: (x, y, z) -> (x, z, −y)).
    x, y, z = load_scenario(args[1]).goal
    np.testing.assert_allclose(objects["goal"], [[x, z, -y]], atol=1e-6)
