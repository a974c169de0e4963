"""What a frame of a camera rig costs on the Fig 11 flights (docs/depth_camera.md,
"Side coverage"): benchmarks/depth_speed.py's replay, summed over the rig's
cameras, for a sensor fixed to the body.

    python docs/results/sweep_depth/side_coverage/frame_cost.py SENSOR [REPEATS]

SENSOR: the sensor as YAML ('default' for the scenario's own camera), e.g.
'!DepthCameraRig {rate_hz: 20.0, cameras: [{}, ...]}'. Prints the best
process CPU time of REPEATS `simulate` calls of each flight and the mean CPU
time [µs] of each piece of a frame over the flight's frames.
"""

import os
import sys
import time

import numpy as np

from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths.layout import OBSTACLE_COUNT
from mfi_drake.maths.perception import Percept, fuse, read
from mfi_drake.studies.sweep import with_overrides
from mfi_drake.world.validation import load_scenario

ROOT = os.path.dirname(os.path.abspath(__file__)) + "/../../../.."
PIECES = ["render", "cloud", "thin", "memory", "segmentation", "pose"]


def frame_costs(flight) -> dict[str, float]:
    """Mean CPU time [µs] of each piece of a frame, and of one reading."""
    scenario = flight.scenario
    built = build_diagram(scenario)
    context = built.diagram.CreateDefaultContext()
    plant = built.plant.GetMyMutableContextFromRoot(context)
    sensor = built.sensor
    n = len(sensor.cameras)
    renders = [built.diagram.GetSubsystemByName(f"rgbd_sensor_{i}") for i in range(n)]
    clouds = [built.diagram.GetSubsystemByName(f"point_cloud_{i}") for i in range(n)]
    render_contexts = [s.GetMyContextFromRoot(context) for s in renders]
    cloud_contexts = [s.GetMyContextFromRoot(context) for s in clouds]
    frames = np.arange(0.0, flight.times[-1], 1.0 / scenario.sensor.rate_hz)
    samples = np.searchsorted(flight.times, frames - 1e-9)
    reach = max(c.max_range for c in sensor.cameras)
    spent = dict.fromkeys([*PIECES, "reading"], 0.0)
    percept = Percept.empty()

    def timed(piece: str, function, *args):
        start = time.process_time()
        result = function(*args)
        spent[piece] += time.process_time() - start
        return result

    for t, k in zip(frames, samples, strict=True):
        x = flight.log["state"][k]
        plant.SetContinuousState(x)
        R_WM, p_WM = timed("pose", sensor.mount_pose, x, None)
        views = []
        for i, camera in enumerate(sensor.cameras):
            port = renders[i].depth_image_32F_output_port()
            depth = timed("render", port.Eval, render_contexts[i])
            port = clouds[i].point_cloud_output_port()
            cloud = timed("cloud", port.Eval, cloud_contexts[i])
            views.append(timed("thin", camera.view, R_WM, p_WM, cloud, depth))
        memory_s = scenario.sensor.memory_s
        memory = timed("memory", fuse, percept.memory, views, t, x[:3], memory_s, reach)
        frames_seen = [view.frame for view in views]
        percept = timed(
            "segmentation", read, memory, frames_seen, x[:3], OBSTACLE_COUNT
        )
        timed("reading", percept.basins.nearest, x[:3])
    return {piece: 1e6 * total / len(frames) for piece, total in spent.items()}


def main() -> None:
    sensor = sys.argv[1]
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    layers = [] if sensor == "default" else [("--set", f"sensor: {sensor}")]
    for name in ["pelican_cylinder.yaml", "pelican_cube.yaml"]:
        scenario = load_scenario(os.path.join(ROOT, "scenarios", name))
        scenario = with_overrides(scenario, layers)
        cpu, flight = [], None
        for _ in range(repeats):
            start = time.process_time()
            flown = simulate(scenario)
            cpu.append(time.process_time() - start)
            flight = flight or flown
        m = flight.metrics
        costs = frame_costs(flight)
        split = ", ".join(f"{piece} {costs[piece]:.0f}" for piece in PIECES)
        print(
            f"{name}: CPU {min(cpu):.2f} s = {m['sim_time'] / min(cpu):.1f}x real "
            f"time, {m.get('frames_rendered')} images, {m['steps']} steps, "
            f"{'success' if m['success'] else 'FAILED'}\n  per frame [µs CPU]: "
            f"{split}; total {sum(costs[p] for p in PIECES):.0f}; a reading "
            f"{costs['reading']:.0f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
