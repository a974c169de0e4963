"""How fast the depth-camera flights of paper Fig 11 run, and what a frame
costs.

    python benchmarks/depth_speed.py [--repeats 3] [--sensor YAML]

For scenarios/pelican_cylinder.yaml and pelican_cube.yaml, flown as
`mfi-drake run` flies them (`flight.simulation.simulate`), the camera fixed to the
body as the files have it and on a gimbal (`gimbal: {}`):

1. the best wall time of Initialize + AdvanceTo over --repeats and its
   real-time factor, the best process CPU time of the whole `simulate` call
   (building the diagram and the metrics included, so an upper bound on the
   flight's) and its real-time factor, the frames and integrator steps; then
   the same flight with the sphere sensor (radius = the camera's max_range)
   instead, so the camera's share shows;
2. the cost of one frame, split, replaying the camera flight's states at its
   frame times through the diagram's own systems: render (the RgbdSensor's
   depth image, VTK), cloud (DepthImageToPointCloud), thin
   (`CameraModel.view`), memory (`perception.fuse`), segmentation
   (`perception.read`: surface links, voxel graph, local minima), pose
   (the mount's pose from the estimate and, on a gimbal, its next angles);
   and the reading between frames (`Groups.nearest`), per evaluation;
   a rig's cameras summed.

With --sensor YAML (e.g. '!DepthCameraRig {rate_hz: 20.0, cameras: [...]}')
each flight is flown with that sensor instead, and parts 1 and 2 are given
for it alone.

The machine's other load shows up in the wall time as noise, hence the best
of several runs and the CPU time beside it.
"""

import argparse
import dataclasses
import os
import time

import numpy as np

from mfi_drake.config.scenario import Scenario, ScenarioError, SphereSensor
from mfi_drake.config.sensors import Gimbal
from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.result import Flight
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths.layout import OBSTACLE_COUNT
from mfi_drake.maths.perception import Percept, fuse, read
from mfi_drake.world.validation import load_scenario

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENARIOS = ["pelican_cylinder.yaml", "pelican_cube.yaml"]
PIECES = ["render", "cloud", "thin", "memory", "segmentation", "pose"]


def best_of(scenario: Scenario, repeats: int) -> tuple[Flight, float]:
    """The flight with the smallest wall time of `repeats` runs, and the
    smallest CPU time [s] of their `simulate` calls."""
    flights, cpu = [], []
    for _ in range(repeats):
        start = time.process_time()
        flights.append(simulate(scenario))
        cpu.append(time.process_time() - start)
    return min(flights, key=lambda f: f.wall_time), min(cpu)


def line(label: str, flight: Flight, cpu: float) -> str:
    m = flight.metrics
    frames = m.get("frames_rendered")
    return (
        f"  {label:<7} {m['sim_time']:4.1f} s simulated: wall {m['wall_time']:5.2f} s "
        f"= {m['realtime_factor']:5.1f}x real time, CPU {cpu:5.2f} s "
        f"= {m['sim_time'] / cpu:5.1f}x, "
        f"{'-' if frames is None else frames} frames, {m['steps']} steps, "
        f"{'success' if m['success'] else 'FAILED'}"
    )


def frame_costs(flight: Flight) -> dict[str, float]:
    """Mean CPU time [µs] of each piece of a frame, and of one reading, over
    the frames of `flight` replayed from its logged states; a rig's cameras
    are summed."""
    scenario = flight.scenario
    built = build_diagram(scenario)
    context = built.diagram.CreateDefaultContext()
    plant = built.plant.GetMyMutableContextFromRoot(context)
    sensor = built.sensor
    sensor_context = sensor.GetMyMutableContextFromRoot(context)
    cameras = []  # (camera model, its RgbdSensor, its cloud system, contexts)
    for i, camera in enumerate(sensor.cameras):
        rgbd = built.diagram.GetSubsystemByName(f"rgbd_sensor_{i}")
        cloud = built.diagram.GetSubsystemByName(f"point_cloud_{i}")
        cameras.append(
            (
                camera,
                rgbd.depth_image_32F_output_port(),
                rgbd.GetMyContextFromRoot(context),
                cloud.point_cloud_output_port(),
                cloud.GetMyContextFromRoot(context),
            )
        )
    reach = max(camera.max_range for camera in sensor.cameras)
    rate = scenario.sensor.rate_hz
    frames = np.arange(0.0, flight.times[-1], 1.0 / rate)
    samples = np.searchsorted(flight.times, frames - 1e-9)
    spent = dict.fromkeys([*PIECES, "reading"], 0.0)
    percept = Percept.empty()

    def timed(piece: str, function, *args):
        start = time.process_time()
        result = function(*args)
        spent[piece] += time.process_time() - start
        return result

    angles = np.zeros(2) if sensor.gimbal else None  # as the flight starts
    for t, k in zip(frames, samples, strict=True):
        x = flight.log["state"][k]
        plant.SetContinuousState(x)
        if sensor.gimbal:
            sensor.set_gimbal_angles(sensor_context, angles)
        R_WM, p_WM = timed("pose", sensor.mount_pose, x, angles)
        if sensor.gimbal:
            angles = timed("pose", sensor.next_gimbal_angles, angles, x)
        views = []
        for camera, depth_port, rgbd_context, cloud_port, cloud_context in cameras:
            depth = timed("render", depth_port.Eval, rgbd_context)
            cloud = timed("cloud", cloud_port.Eval, cloud_context)
            views.append(timed("thin", camera.view, R_WM, p_WM, cloud, depth))
        memory = timed(
            "memory",
            fuse,
            percept.memory,
            views,
            t,
            x[:3],
            scenario.sensor.memory_s,
            reach,
        )
        seen = [view.frame for view in views]
        percept = timed("segmentation", read, memory, seen, x[:3], OBSTACLE_COUNT)
        timed("reading", percept.basins.nearest, x[:3])
    return {piece: 1e6 * total / len(frames) for piece, total in spent.items()}


def print_frame_costs(label: str, flight: Flight) -> None:
    costs = frame_costs(flight)
    split = ", ".join(f"{piece} {costs[piece]:.0f}" for piece in PIECES)
    print(
        f"  {label} per frame [µs CPU]: {split}; "
        f"total {sum(costs[p] for p in PIECES):.0f}"
        f"; a reading between frames {costs['reading']:.0f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--sensor",
        metavar="YAML",
        help="fly this sensor instead (e.g. a !DepthCameraRig), as --set "
        "'sensor: YAML' would",
    )
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error(f"--repeats = {args.repeats}: must be >= 1")
    layers = [] if args.sensor is None else [("--sensor", f"sensor: {args.sensor}")]
    for name in SCENARIOS:
        try:
            scenario = load_scenario(os.path.join(ROOT, "scenarios", name), layers)
        except ScenarioError as e:
            parser.error(str(e))
        if args.sensor is not None:
            flight, cpu = best_of(scenario, args.repeats)
            print(f"{scenario.name} (best of {args.repeats})")
            print(line("sensor", flight, cpu))
            print_frame_costs("sensor", flight)
            continue
        camera = scenario.sensor
        print(
            f"{scenario.name}: depth camera {camera.width}x{camera.height}, "
            f"{camera.rate_hz:g} frames/s (best of {args.repeats})"
        )
        # As the scenario has it (fixed to the body), then on the gimbal.
        gimballed = dataclasses.replace(camera, gimbal=Gimbal())
        flights = {}
        for label, sensor in (("depth", camera), ("gimbal", gimballed)):
            flight, cpu = best_of(
                dataclasses.replace(scenario, sensor=sensor), args.repeats
            )
            print(line(label, flight, cpu))
            flights[label] = flight
        sphere = dataclasses.replace(
            scenario, sensor=SphereSensor(radius=camera.max_range)
        )
        print(line("sphere", *best_of(sphere, args.repeats)))
        for label, flight in flights.items():
            print_frame_costs(label, flight)


if __name__ == "__main__":
    main()
