"""The commands of studies on random fields: `sweep` and `tune`, each its
parser (`add_sweep`, `add_tune`) and what it does (`cmd_sweep`, ...; the
`scene` command, which shares `sweep_config`, is `scene_command`):
check the arguments, hand them to `studies` (the sweep, the fleet sweep,
the tuning protocol), print and write the results."""

import json
import os
import sys
from functools import partial

from mfi_drake.app.arguments import (
    UsageError,
    add_field_count,
    add_motion,
    add_overrides,
    add_parser,
    add_random_field,
    add_workers,
    at_least,
    check_field_numbers,
    check_held_out_numbers,
    check_motion_numbers,
    check_sweep_numbers,
    exit_statuses,
    json_safe,
    overrides,
    parse_methods,
)
from mfi_drake.config.scenario_yaml import layered_name, read_faults
from mfi_drake.flight.methods import DEFAULT_METHODS
from mfi_drake.world.validation import validate_scenario


def check_world(args) -> None:
    """--world: a generated world has its own start, goal and obstacles, so
    the options that shape random fields are refused with it; random fields
    get the default density where --density is absent."""
    from mfi_drake.studies.records import RANDOM
    from mfi_drake.world.generator import DEFAULT_DENSITY

    if args.world == RANDOM:
        args.density = args.density or [DEFAULT_DENSITY]
        return
    shaping = {
        "--density": " ".join(f"{d:g}" for d in args.density or []),
        "--vehicles": args.vehicles if args.vehicles > 1 else "",
        "--moving": args.moving or "",
        "--goal-clearance": "" if args.goal_clearance is None else args.goal_clearance,
    }
    for flag, given in shaping.items():
        if given != "":
            raise UsageError(
                f"{flag} = {given}: shapes the random fields, not --world {args.world}"
            )
    args.density = []


def check_held_out_world(args) -> None:
    """--held-out-world: generated worlds have no density, so
    --held-out-density is refused with them; random fields get the default
    densities where it is absent."""
    from mfi_drake.studies.records import RANDOM
    from mfi_drake.studies.tune import HELD_OUT_DENSITIES

    if args.held_out_world == RANDOM:
        args.held_out_density = args.held_out_density or list(HELD_OUT_DENSITIES)
    elif args.held_out_density:
        given = " ".join(f"{d:g}" for d in args.held_out_density)
        raise UsageError(
            f"--held-out-density = {given}: shapes the random fields, not "
            f"--held-out-world {args.held_out_world}"
        )


def sweep_config(args, **more):
    """(config, tasks) of the random fields the arguments name (seed,
    sensor, vehicles, motion, goal clearance; checked here): a fleet's
    (`studies.fleet_sweep`) where --vehicles > 1. `more`: further fields of
    the configuration."""
    from mfi_drake.studies.fleet_sweep import FLEET, FleetSweepConfig
    from mfi_drake.studies.sweep import SINGLE, SweepConfig

    check_field_numbers(args)
    check_motion_numbers(args)
    at_least("--vehicles", args.vehicles, 1)
    fleet = args.vehicles > 1
    if fleet and args.goal_clearance is not None:
        # random_pairs draws a fleet's goals anew, away from that obstacle.
        raise UsageError(
            f"--goal-clearance = {args.goal_clearance}: places an obstacle near "
            "the one vehicle's goal; not with --vehicles > 1 (a fleet's goals "
            "are drawn anew)"
        )
    config = (FleetSweepConfig if fleet else SweepConfig)(
        **({"vehicles": args.vehicles} if fleet else {}),
        seed=args.seed,
        sensor=args.sensor,
        moving=args.moving,
        obstacle_speed=args.obstacle_speed,
        goal_clearance=args.goal_clearance,
        **more,
    )
    return config, (FLEET if fleet else SINGLE)


def _need_dask() -> None:
    from mfi_drake.studies.cluster import ClusterError, require_dask

    try:
        require_dask()
    except ClusterError as e:
        raise UsageError(str(e)) from None


def cmd_sweep(args) -> int:
    _need_dask()
    from mfi_drake.flight.fleet import check_engine, not_compiled
    from mfi_drake.studies.cluster import ClusterError, dask_client
    from mfi_drake.studies.fleet_sweep import FLEET, fleet_variant
    from mfi_drake.studies.sweep import SINGLE, default_engine, field_to_fly, run_sweep
    from mfi_drake.studies.variants import (
        goal_variant,
        layered,
        motion_variant,
        variant_name,
    )

    methods = parse_methods(args.methods) if args.methods else list(DEFAULT_METHODS)
    check_sweep_numbers(args)
    check_world(args)
    config, tasks = sweep_config(
        args,
        n=args.n,
        methods=methods,
        densities=list(dict.fromkeys(args.density)),
        out=args.out,
        world=args.world,
    )
    fleet = tasks is FLEET
    if fleet and args.faults is not None:
        raise UsageError(
            f"--faults = {args.faults!r}: not with --vehicles > 1 (a fleet's "
            "vehicles fly without faults)"
        )
    texts = overrides(args)
    faults = None
    if args.faults is not None:
        faults = read_faults(args.faults, f"--faults {args.faults!r}")
    config.variant = variant_name(
        texts,
        faults,
        motion_variant(args.moving, args.obstacle_speed),
        goal_variant(args.goal_clearance),
    )
    if fleet:
        config.variant = fleet_variant(args.vehicles, config.variant)
    modify = partial(layered, overrides=texts, faults=faults)
    if tasks is SINGLE:  # fleets fly on one integrator where it applies
        modify = default_engine(config, tasks, modify)
    # The first field with every layer, checked before a cluster starts or
    # anything is written (run_sweep checks it too, for the API's callers).
    first = field_to_fly(config, tasks, modify, config.flight_keys()[0])
    validate_scenario(first, layered_name(first.name, texts))
    check_engine(first, methods)
    # Said with the results (a refusal below stays one line).
    why = not_compiled(first, methods) if first.engine == "systems" else None
    try:
        with dask_client(args.workers, args.scheduler, methods) as client:
            run = run_sweep(config, client, modify, tasks=tasks)
    except KeyboardInterrupt:
        print(
            f"mfi-drake: interrupted; finished flights are in {args.out}/results.jsonl,"
            " rerun the same command to fly the rest",
            file=sys.stderr,
        )
        return 130
    except ClusterError as e:  # unreachable, refused, no workers, ...
        raise UsageError(str(e)) from None
    _report_sweep(args, run, fleet, why if tasks is SINGLE else None)
    return 1 if run.lost else 0


def _report_sweep(args, run, fleet: bool, why: str | None) -> None:
    """Plots and prints a sweep's `run`: its summary (as JSON with --json),
    the flights it could not run, and `why` a single-vehicle sweep flew on
    the systems engine (None: it did not, or it is a fleet's)."""
    from mfi_drake.app.figures import plot_fleet_sweep, plot_sweep
    from mfi_drake.studies.fleet_sweep import fleet_table
    from mfi_drake.studies.stats import summary_table

    plot = plot_fleet_sweep if fleet else plot_sweep
    plot(run.summary, os.path.join(args.out, "sweep.png"))
    if args.json:
        print(json.dumps(json_safe(run.summary)))
    else:
        print((fleet_table if fleet else summary_table)(run.summary))
        print(
            f"flew {run.ran}, found {run.skipped} done; wrote {args.out}/: "
            "results.jsonl, summary.json, table.md, sweep.png, failures/"
        )
        if why is not None:
            print(f"engine: systems ({why})")
    for line in run.lost:
        print(f"mfi-drake: not run (rerun to retry): {line}", file=sys.stderr)


def cmd_tune(args) -> int:
    _need_dask()
    from mfi_drake.app.figures import plot_sweep
    from mfi_drake.studies.cluster import ClusterError, dask_client
    from mfi_drake.studies.stats import summary_table
    from mfi_drake.studies.tune import TuneConfig, TuneError, held_out_sweep, tune

    methods = parse_methods(args.methods)
    check_sweep_numbers(args)
    check_field_numbers(args)
    check_motion_numbers(args)
    check_held_out_world(args)
    check_held_out_numbers(args)
    config = TuneConfig(
        methods=methods,
        candidates=args.candidates,
        seed=args.seed,
        n=args.n,
        densities=list(dict.fromkeys(args.density)),
        paper_scenarios=args.paper_scenarios,
        walls=args.walls,
        moving=args.moving,
        obstacle_speed=args.obstacle_speed,
        jitter=args.jitter,
        held_out_seed=args.held_out_seed,
        held_out_world=args.held_out_world,
        out=args.out,
    )
    try:
        config.check()
    except TuneError as e:
        raise UsageError(str(e)) from None
    if args.held_out_seed is None:
        print(
            "mfi-drake: warning: no --held-out-seed: the tuned gains will not be "
            "flown on held-out fields",
            file=sys.stderr,
        )
    try:
        with dask_client(args.workers, args.scheduler, methods) as client:
            tune(config, client)
            print(f"wrote {args.out}/tuned.yaml, tuning.md, tuning.json, tune.jsonl")
            if args.held_out_seed is None:
                return 0
            run = held_out_sweep(config, client, args.held_out_n, args.held_out_density)
    except (TuneError, ClusterError) as e:
        raise UsageError(str(e)) from None
    held_out = os.path.join(args.out, "held_out")
    plot_sweep(run.summary, os.path.join(held_out, "sweep.png"))
    print(summary_table(run.summary))
    print(f"wrote {held_out}/ (held-out fields, seed {args.held_out_seed})")
    return 1 if run.lost else 0


def add_world(parser, flag: str, what: str, count: str) -> None:
    """A flag naming the worlds flown: random fields (the default), a class
    of the generated non-convex worlds, or every class."""
    from mfi_drake.studies.sweep import NONCONVEX, WORLDS

    parser.add_argument(
        flag,
        choices=WORLDS,
        default=WORLDS[0],
        metavar="KIND",
        help=f"{what}, one of {', '.join(WORLDS)}: random obstacle fields, or "
        f"{count} generated non-convex worlds of a class or of every class "
        f"({NONCONVEX}) (docs/nonconvex.md)",
    )


def add_sweep(sub) -> None:
    """The `sweep` command's parser, added to the subparsers `sub`."""
    sweep = add_parser(
        sub,
        "sweep",
        "Monte Carlo benchmark on random obstacle fields or generated worlds (Dask)",
        exit_status=exit_statuses(
            "every flight was flown, whatever its outcome (the rates are the output)",
            "a flight could not be run (rerun the same command to fly it)",
        ),
    )
    add_overrides(sweep)
    add_field_count(sweep, 30, "fields", "density or --world class")
    add_world(sweep, "--world", "the fields flown", "--n")
    sweep.add_argument(
        "--methods",
        metavar="M,M,...",
        help="distinct names or MODULE:NAME, separated by commas, e.g. mfi,apf,gf "
        f"(default: every method of the registry: {','.join(DEFAULT_METHODS)})",
    )
    add_random_field(sweep, several=True)
    sweep.add_argument(
        "--vehicles",
        metavar="V",
        type=int,
        default=1,
        help="vehicles per field, ≥ 1, between random start and goal pairs at the "
        "ends of the box, half each way (1: the single-vehicle sweep)",
    )
    add_workers(sweep)
    sweep.add_argument(
        "--faults",
        metavar="YAML",
        help="a scenario `faults:` block flown on every field, as YAML, e.g. "
        "'{sensor_noise_std: 0.05, dropout_prob: 0.1}' (each field's seed is "
        "offset by its name); results are keyed by it, so several can share "
        "--out (default: none)",
    )
    sweep.add_argument(
        "--out", metavar="DIR", default="out/sweep", help="output directory"
    )
    sweep.add_argument(
        "--json", action="store_true", help="print the summary as one JSON object"
    )
    sweep.set_defaults(func=cmd_sweep)


def add_tune(sub) -> None:
    """The `tune` command's parser, added to the subparsers `sub`."""
    # Over 80 lines: one flat declaration of the command's flags, in the
    # order --help lists them; split, it would read worse.
    from mfi_drake.studies.tune import (
        HELD_OUT_DENSITIES,
        HELD_OUT_N,
        JITTER_AXES,
        MIN_CANDIDATES,
    )

    tune = add_parser(
        sub,
        "tune",
        "one tuning protocol for every method, then held-out fields (Dask)",
        exit_status=exit_statuses(
            "tuned.yaml and, with --held-out-seed, the held-out sweep are written",
            "a held-out flight could not be run (rerun the same command to fly it)",
        ),
    )
    tune.add_argument(
        "--methods",
        metavar="M,M,...",
        default=",".join(DEFAULT_METHODS),
        help="distinct names or MODULE:NAME, separated by commas",
    )
    tune.add_argument(
        "--candidates",
        metavar="C",
        type=int,
        default=24,
        help=f"gain sets tried per method, ≥ {MIN_CANDIDATES}: the current gains, "
        "a Latin hypercube of two thirds of the rest, then two rounds of "
        "refinement; the budget is candidates × training fields flights",
    )
    tune.add_argument(
        "--seed", metavar="S", type=int, default=100, help="training fields' seed, ≥ 0"
    )
    add_field_count(tune, 10, "random training fields")
    tune.add_argument(
        "--density",
        metavar="D",
        type=float,
        nargs="+",
        default=[0.1, 0.2],
        help="training densities, obstacles per m³, each ≥ 0",
    )
    tune.add_argument(
        "--paper-scenarios",
        metavar="DIR",
        help="a directory whose paper scenarios join training (default: none)",
    )
    tune.add_argument(
        "--walls",
        metavar="W",
        type=int,
        default=0,
        help="wall fields that join training, ≥ 0",
    )
    add_motion(tune, "each random training field also flown with this share moving")
    tune.add_argument(
        "--jitter",
        metavar="J",
        type=int,
        default=1,
        help="fly each random training field this many times, started 1 mm "
        f"apart, 1 (once) to {1 + len(JITTER_AXES)}",
    )
    tune.add_argument(
        "--held-out-seed",
        metavar="H",
        type=int,
        help="seed of the held-out fields the winners are then flown on, ≥ 0 and "
        "≠ --seed (default: none, no held-out phase, with a warning)",
    )
    tune.add_argument(
        "--held-out-n",
        metavar="N",
        type=int,
        default=HELD_OUT_N,
        help="held-out fields per density, ≥ 1",
    )
    tune.add_argument(
        "--held-out-density",
        metavar="D",
        type=float,
        nargs="+",
        help="held-out densities of the random fields, obstacles per m³, each "
        f"≥ 0 (default: {' '.join(f'{d:g}' for d in HELD_OUT_DENSITIES)})",
    )
    add_world(tune, "--held-out-world", "what the winners are flown on", "--held-out-n")
    add_workers(tune)
    tune.add_argument(
        "--out", metavar="DIR", default="out/tune", help="output directory"
    )
    tune.set_defaults(func=cmd_tune)
