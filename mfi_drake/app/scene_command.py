"""The `scene` command: its parser (`add_scene`) and what it does
(`cmd_scene`): a scenario file of N vehicles (an antipodal circle, crossing
streams, or a sweep's random field), validated as `run` would."""

import math
from collections.abc import Callable
from functools import partial

from mfi_drake.app.arguments import (
    UsageError,
    add_parser,
    add_random_field,
    at_least,
    exit_statuses,
)
from mfi_drake.app.study_commands import sweep_config
from mfi_drake.world.validation import validate_scenario

# Each kind of `scene` and the options that shape it (the rest: every kind).
SCENE_OPTIONS = {
    "circle": ("radius", "height", "duration"),
    "streams": ("length", "spacing", "height"),
    "field": (
        "seed",
        "density",
        "index",
        "moving",
        "obstacle_speed",
        "goal_clearance",
    ),
}


def cmd_scene(default_of: Callable[[str], object], args) -> int:
    """`default_of`: the scene parser's default of an option (its get_default),
    which tells an option given from one left alone."""
    from dataclasses import replace

    from mfi_drake.studies.sweep import SENSORS
    from mfi_drake.world.fleets import antipodal_circle, crossing_streams
    from mfi_drake.world.generator import write_scenario

    shaping = {name for names in SCENE_OPTIONS.values() for name in names}
    for name in sorted(shaping - set(SCENE_OPTIONS[args.kind])):
        given = getattr(args, name)
        if given != default_of(name):
            kinds = " or ".join(k for k, ns in SCENE_OPTIONS.items() if name in ns)
            flag = "--" + name.replace("_", "-")
            raise UsageError(f"{flag} = {given}: shapes a {kinds} scene only")
    if not args.out.endswith((".yaml", ".yml")):
        raise UsageError(f"--out = {args.out!r}: must name a .yaml file")
    if args.vehicles is None:
        args.vehicles = 1 if args.kind == "field" else 8
    at_least("--vehicles", args.vehicles, 1)
    for name in ("radius", "length", "spacing", "duration"):
        value = getattr(args, name)
        if value is not None and not (math.isfinite(value) and value > 0.0):
            raise UsageError(f"--{name} = {value}: must be a finite number > 0")
    if args.kind == "field":
        at_least("--index", args.index, 0)
        config, tasks = sweep_config(args)
        scene = tasks.make_field(config, args.density, args.index)
    else:
        if args.kind == "circle":
            scene = antipodal_circle(
                args.vehicles, args.radius, args.height, args.duration
            )
        else:
            scene = crossing_streams(
                args.vehicles, args.length, args.spacing, args.height
            )
        scene = replace(scene, sensor=SENSORS[args.sensor]())
    validate_scenario(scene, args.out)
    header = f"# written by `mfi-drake scene {args.kind}`; fly it: `mfi-drake run`\n"
    write_scenario(scene, args.out, header=header)
    count = 1 + len(scene.other_vehicles)
    print(f"wrote {args.out}: {scene.name}, {count} vehicle(s), {scene.duration:g} s")
    return 0


def add_scene(sub) -> None:
    """The `scene` command's parser, added to the subparsers `sub`."""
    scene = add_parser(
        sub,
        "scene",
        "write a scenario file of N vehicles: an antipodal circle, crossing "
        "streams, or a sweep's random field",
        exit_statuses("the scenario is written, validated as `run` would"),
        description="Writes a scenario file of N vehicles, validated as `run` "
        "would, with every obstacle inline: 'circle' puts them evenly on a "
        "horizontal circle, each flying to the opposite point (all meet in the "
        "middle); 'streams' makes two streams abreast crossing at right angles; "
        "'field' is the random field `sweep` flies for --seed, --density, "
        "--index and --vehicles (1: the single-vehicle sweep's field). Options "
        "that shape another kind are refused. Fly it with `mfi-drake run FILE`.",
    )
    scene.add_argument("kind", choices=list(SCENE_OPTIONS), help="the kind of scene")
    scene.add_argument(
        "--vehicles",
        metavar="V",
        type=int,
        help="vehicles, ≥ 1 (default: 8; 1 for field)",
    )
    scene.add_argument(
        "--radius",
        type=float,
        metavar="M",
        help="circle: its radius, > 0 (default: 6 m, or wider so that "
        "neighbours are 2 m apart along it)",
    )
    scene.add_argument(
        "--duration",
        type=float,
        metavar="T",
        help="circle: simulated seconds, > 0 (default: 5 s per metre of diameter)",
    )
    scene.add_argument(
        "--height", type=float, default=2.0, metavar="M", help="circle, streams: z"
    )
    scene.add_argument(
        "--length",
        type=float,
        default=12.0,
        metavar="M",
        help="streams: each vehicle's start–goal distance, > 0",
    )
    scene.add_argument(
        "--spacing",
        type=float,
        default=1.5,
        metavar="M",
        help="streams: between neighbours abreast, > 0",
    )
    add_random_field(scene, several=False)
    scene.add_argument(
        "--index",
        metavar="I",
        type=int,
        default=0,
        help="field: which field of the seed, ≥ 0",
    )
    scene.add_argument(
        "--out", metavar="FILE.yaml", required=True, help="the .yaml file to write"
    )
    scene.set_defaults(func=partial(cmd_scene, scene.get_default), out_is_file=True)
