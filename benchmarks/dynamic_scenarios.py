"""The shipped dynamic scenarios, every method, each way a navigator can see
motion (docs/dynamic.md).

    python benchmarks/dynamic_scenarios.py [--methods mfi,apf,gf,mfi-paper]
                                           [--out docs/results/moving]

Flies moving_head_on, moving_crossing and moving_wandering with the sphere
sensor and the depth camera, swarm_corridor and swarm_circle (sphere sensor:
other vehicles fly with it only) and tree_on_ground, with the velocity
relative to each obstacle keeping the own pace (the default), the relative
fields as they are, and the vehicle's own velocity (the estimate off; the
tree's scene is static, so it is flown once). Writes DIR/scenarios.md: the
outcome, the least clearance, the least separation between vehicles, and the
cost, simulated seconds per process CPU second.
"""

import argparse
import os

from mfi_drake.files import write_text
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.validation import load_scenario

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WAYS = {
    "relative, own pace": "relative_velocity: {own_pace: true}",
    "relative, full": "relative_velocity: {own_pace: false}",
    "own velocity": "relative_velocity: {enabled: false}",
}
CAMERA = "sensor: !DepthCamera {}"
FLOWN = [  # (scenario, its sensors, whether anything moves)
    ("moving_head_on", ("sphere", "camera"), True),
    ("moving_crossing", ("sphere", "camera"), True),
    ("moving_wandering", ("sphere", "camera"), True),
    ("swarm_corridor", ("sphere",), True),
    ("swarm_circle", ("sphere",), True),
    ("tree_on_ground", ("sphere",), False),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", default="mfi,apf,gf,mfi-paper")
    parser.add_argument("--out", default="docs/results/moving")
    args = parser.parse_args()
    rows = []
    for name, sensors, moving in FLOWN:
        path = os.path.join(ROOT, "scenarios", f"{name}.yaml")
        for sensor in sensors:
            for way, text in WAYS.items() if moving else [("(static)", "")]:
                layers = [(way, text)] if text else []
                if sensor == "camera":
                    layers.append(("camera", CAMERA))
                for method in args.methods.split(","):
                    flight = simulate(load_scenario(path, layers), method)
                    rows.append((name, sensor, way, method, flight))
                    print(row(*rows[-1]), flush=True)
        write_text(os.path.join(args.out, "scenarios.md"), table(rows))


def _metres(value) -> str:
    return "–" if value is None else f"{value:.3f}"


def row(name, sensor, way, method, flight) -> str:
    m = flight.metrics
    cost = m["sim_time"] / flight.cpu_time
    return (
        f"| {name} | {sensor} | {way} | {method} | {m['outcome']} "
        f"| {_metres(m['min_clearance'])} | {_metres(m.get('min_separation'))} "
        f"| {m['path_length']:.2f} | {cost:.0f} |"
    )


def table(rows) -> str:
    lines = [
        "# The shipped dynamic scenarios",
        "",
        "Written by `python benchmarks/dynamic_scenarios.py`. Clearance: to "
        "obstacles and the ground, from the collision sphere; separation: "
        "between two vehicles' collision spheres; cost: simulated s per CPU s.",
        "",
        "| scenario | sensor | how the navigator sees motion | method | outcome "
        "| min clearance [m] | min separation [m] | path [m] | sim s / CPU s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    return "\n".join(lines + [row(*r) for r in rows]) + "\n"


if __name__ == "__main__":
    main()
