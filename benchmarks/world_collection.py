"""A public collection of world files as its repository ships it: every
file loaded, and with --fly flown past, each in a process of its own, so a
crash or a hang is counted, not fatal (docs/world_files.md).

    python benchmarks/world_collection.py FOLDER [--pattern '*/model.sdf']
        [--model-paths DIR ...] [--fly] [--timeout 240] [--out DIR]

Every file under FOLDER matching --pattern (a glob relative to FOLDER;
default: every .world, .sdf and .urdf, and every .xml whose root is
<mujoco>), in name order:

- loaded by `world_files.world_obstacles` (its `model://` includes searched
  in FOLDER and each --model-paths): "ok" (obstacles, ground, seconds),
  "refused" (the loader's one line), or "died" (a traceback, a crash, or
  --timeout seconds passed: the last line it wrote);
- with --fly, flown past by the default `mfi` (the sphere sensor): from 3 m
  before the file's obstacles along x to 3 m beyond them, at their middle
  height but at least 1 m above the ground, 60 s, as `mfi-drake run` loads
  a scenario: its outcome, least clearance, path and real-time factor, or
  the scenario's one-line refusal (a start or goal inside the world).

Prints a line a file and the counts; writes DIR/collection.jsonl and
DIR/collection.md (default out/collection).
"""

import argparse
import collections
import fnmatch
import json
import os
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import numpy as np

from mfi_drake.config import scenario as sc
from mfi_drake.files import write_text
from mfi_drake.world.shapes import bounding_radius

SUFFIXES = (".world", ".sdf", ".urdf")
MARGIN = 3.0  # m before and beyond the world's obstacles
DURATION = 60.0  # s of flight past a world


def collection(folder: str, pattern: str | None) -> list[str]:
    """The files of the collection, relative to `folder`, in name order."""
    found = []
    for root, _, names in os.walk(folder):
        for name in names:
            relative = os.path.relpath(os.path.join(root, name), folder)
            if pattern is not None:
                if fnmatch.fnmatch(relative, pattern):
                    found.append(relative)
            elif name.lower().endswith(SUFFIXES) or _is_mjcf(os.path.join(root, name)):
                found.append(relative)
    return sorted(found)


def _is_mjcf(path: str) -> bool:
    if not path.lower().endswith(".xml"):
        return False
    try:
        return next(ET.iterparse(path, events=("start",)))[1].tag == "mujoco"
    except (ET.ParseError, OSError, StopIteration):
        return False


def flight_past(path: str, world, model_paths: list[str], out: str) -> dict:
    """The default MFI flown past `world` (the file `path` loaded)."""
    from mfi_drake.config.scenario import ScenarioError
    from mfi_drake.flight.simulation import simulate
    from mfi_drake.world.validation import load_scenario

    alone = sc.Scenario()  # a world's pieces hold their vertices inline
    centres = np.array([o.position for o in world.obstacles] or [[0.0] * 3])
    reaches = [bounding_radius(alone, o.shape) for o in world.obstacles] or [0.0]
    reaches = np.asarray(reaches)
    low = (centres - reaches[:, None]).min(axis=0)
    high = (centres + reaches[:, None]).max(axis=0)
    ground = low[2] - 1.0 if world.ground is None else world.ground
    z = float(max((low[2] + high[2]) / 2, ground + 1.0))
    y = float((low[1] + high[1]) / 2)
    yaml = os.path.join(out, "past.yaml")
    write_text(
        yaml,
        f"name: past\nstart: [{low[0] - MARGIN}, {y}, {z}]\n"
        f"goal: [{high[0] + MARGIN}, {y}, {z}]\nduration: {DURATION}\n"
        f"sensor: !SphereSensor {{radius: 3.0}}\nworld: {os.path.abspath(path)}\n"
        f"model_paths: {json.dumps(model_paths)}\n",
    )
    try:
        scenario = load_scenario(yaml)
    except ScenarioError as e:
        return {"flight": "refused", "why": str(e).splitlines()[0][-200:]}
    started = time.perf_counter()
    metrics = simulate(scenario).metrics
    wall = time.perf_counter() - started
    return {
        "flight": metrics["outcome"],
        "clearance": round(float(metrics["min_clearance"]), 3),
        "path": round(float(metrics["path_length"]), 2),
        "real_time": round(DURATION / wall, 1),
    }


def one(path: str, label: str, model_paths: list[str], fly: bool, out: str) -> dict:
    """One file loaded (and flown): its record."""
    from mfi_drake.world.world_files import world_obstacles

    started = time.perf_counter()
    try:
        world = world_obstacles(path, label, model_paths)
    except ValueError as e:
        return {"file": label, "load": "refused", "why": str(e)}
    record = {
        "file": label,
        "load": "ok",
        "obstacles": len(world.obstacles),
        "ground": world.ground,
        "seconds": round(time.perf_counter() - started, 2),
    }
    if fly:
        record |= flight_past(path, world, model_paths, out)
    return record


def in_a_process(args, label: str) -> dict:
    """`one` in a fresh interpreter: a crash or a hang is its record."""
    scratch = os.path.join(args.out, "scratch")
    os.makedirs(scratch, exist_ok=True)
    command = [sys.executable, __file__, args.folder, "--one", label]
    command += ["--out", scratch, "--model-paths", *args.model_paths]
    command += ["--fly"] * args.fly
    try:
        done = subprocess.run(
            command, capture_output=True, text=True, timeout=args.timeout
        )
    except subprocess.TimeoutExpired:
        return {"file": label, "load": "died", "why": f"over {args.timeout} s"}
    lines = done.stdout.strip().splitlines()
    if done.returncode == 0 and lines:
        return json.loads(lines[-1])
    said = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
    return {"file": label, "load": "died", "why": said}


def table(records: list[dict], fly: bool) -> str:
    loads = collections.Counter(r["load"] for r in records)
    lines = [
        f"{len(records)} files: {loads['ok']} loaded, {loads['refused']} refused "
        f"in one line, {loads['died']} died.",
        "",
    ]
    if fly:
        flights = collections.Counter(r["flight"] for r in records if "flight" in r)
        lines += [
            "Flown past (default mfi, 60 s): "
            + ", ".join(f"{n} {k}" for k, n in sorted(flights.items())),
            "",
        ]
    lines += ["| file | load | obstacles | flight | why |", "|---|---|---|---|---|"]
    for r in records:
        flight = r.get("flight", "–")
        if "clearance" in r:
            flight += f" ({r['clearance']} m clear, {r['path']} m)"
        lines.append(
            f"| {r['file']} | {r['load']} | {r.get('obstacles', '–')} | {flight} "
            f"| {r.get('why', '')} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("--pattern", default=None)
    parser.add_argument("--model-paths", nargs="*", default=[])
    parser.add_argument("--fly", action="store_true")
    parser.add_argument("--timeout", type=float, default=240.0)
    parser.add_argument("--out", default=os.path.join("out", "collection"))
    parser.add_argument("--one", help=argparse.SUPPRESS)  # a child's file
    args = parser.parse_args(argv)
    args.model_paths = [args.folder, *args.model_paths]
    if args.one is not None:
        path = os.path.join(args.folder, args.one)
        record = one(path, args.one, args.model_paths, args.fly, args.out)
        print(json.dumps(record))
        return
    if not os.path.isdir(args.folder):
        parser.exit(
            2, f"world_collection.py: error: FOLDER = {args.folder!r}: no such folder\n"
        )
    files = collection(args.folder, args.pattern)
    if not files:
        parser.exit(
            2, f"world_collection.py: error: no file of {args.folder} matches\n"
        )
    records = []
    for label in files:
        records.append(in_a_process(args, label))
        r = records[-1]
        print(f"{label}: {r['load']} {r.get('flight', '')} {r.get('why', '')}"[:160])
    text = table(records, args.fly)
    write_text(os.path.join(args.out, "collection.md"), text)
    write_text(
        os.path.join(args.out, "collection.jsonl"),
        "".join(json.dumps(r) + "\n" for r in records),
    )
    print(text.split("\n\n")[0])


if __name__ == "__main__":
    main()
