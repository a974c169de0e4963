"""Regenerates every published result set, then the docs' tables from them.

    python benchmarks/publish.py [--only NAME ...] [--workers 2]
                                 [--scheduler ADDRESS] [--tables-only]
                                 [--root DIR] [--list]

docs/results/published.toml lists each published set: where it lives, the
commands that write it (seeds and configuration in full) and the files git
keeps of it. Without --tables-only every set's commands are run in turn from
the repository root; the sweeps and tunings resume from the per-flight
records they keep beside their summaries (ignored by git), so a killed run
picks up where it stopped. --workers replaces the recorded `--workers 2`, and
--scheduler (a Dask scheduler's address) is added to every `mfi-drake sweep`
and `tune`, so the flights run on that cluster.

Then, and alone with --tables-only, each table between the markers
`<!-- BEGIN publish:NAME -->` and `<!-- END publish:NAME -->` of README.md
and the docs pages is written again from the committed summaries (`--root DIR`: the
summaries and pages of a copy of the repository; tests/test_publish.py
checks that the committed pages equal what this renders). --list prints
the files git keeps, one a line.
"""

import argparse
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from collections.abc import Callable

from mfi_drake.files import write_section
from mfi_drake.flight.methods import appearance
from mfi_drake.studies.fleet_sweep import fleet_table
from mfi_drake.world.nonconvex import KINDS

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MANIFEST = os.path.join("docs", "results", "published.toml")
PAGES = [
    "README.md",
    "docs/comparison.md",
    "docs/depth_camera.md",
    "docs/robustness.md",
    "docs/fleets.md",
    "docs/goals.md",
    "docs/nonconvex.md",
]
RESULTS = "docs/results"
FLEETS = ("fleet_4", "fleet_8", "fleet_16_one", "fleet_8_methods")  # the fleet sweeps
NONCONVEX = "nonconvex_4343"  # the held-out sweep of the generated worlds
# The benchmark-world classes (`sweep --world KIND`), each a set of its own.
BENCHMARK_WORLDS = ("clutter", "floorplan")
NOT_REACHED = ("collision", "timeout", "trapped")  # its outcomes counted
DENSITIES = ("0.05", "0.1", "0.2")
# Row labels of the methods, as the tables name them.
LABELS = {
    "mfi": "MFI",
    "mfi-paper": "MFI (paper)",
    "apf": "APF",
    "gf": "GF",
}
# The pages' sections publish.py writes: `<!-- BEGIN publish:NAME -->` …
# `<!-- END publish:NAME -->` (files.write_section's markers).
SECTION = re.compile(r"<!-- BEGIN publish:([a-z_0-9]+) -->")


# --- the manifest and the commands ------------------------------------------
def published_sets(root: str = ROOT) -> list[dict]:
    with open(os.path.join(root, MANIFEST), "rb") as f:
        return tomllib.load(f)["set"]


def kept_files(root: str = ROOT) -> list[str]:
    """Every file git keeps of the published sets, from the root."""
    return [
        os.path.normpath(os.path.join(s["path"], k))
        for s in published_sets(root)
        for k in s["keep"]
    ]


def command_argv(command: str, workers: int, scheduler: str | None) -> list[str]:
    """A recorded command as the argv to run: `mfi-drake` and `python` are
    this interpreter's, `--workers 2` becomes --workers, and a sweep or tune
    gets --scheduler."""
    argv = shlex.split(command)
    if argv[0] == "python":
        argv[0] = sys.executable
    elif argv[0] == "mfi-drake":
        here = os.path.dirname(sys.executable)
        argv[0] = shutil.which("mfi-drake", path=here) or "mfi-drake"
        if scheduler and argv[1] in ("sweep", "tune"):
            argv += ["--scheduler", scheduler]
    if "--workers" in argv:
        argv[argv.index("--workers") + 1] = str(workers)
    return argv


def command_env(command: str) -> tuple[dict[str, str], str]:
    """(the environment, the command without them): a recorded command may
    begin with NAME=VALUE settings, as in a shell (PYTHONPATH=benchmarks for
    the README's example field)."""
    words = shlex.split(command)
    env = dict(os.environ)
    while words and re.fullmatch(r"[A-Z_]+=.*", words[0]):
        name, value = words.pop(0).split("=", 1)
        env[name] = value
    return env, shlex.join(words)


def regenerate(sets: list[dict], workers: int, scheduler: str | None) -> None:
    for s in sets:
        for command in s["commands"]:
            env, rest = command_env(command)
            argv = command_argv(rest, workers, scheduler)
            print(f"== {s['path']}: {shlex.join(argv)}", flush=True)
            subprocess.run(argv, cwd=ROOT, check=True, env=env)


# --- reading the summaries -------------------------------------------------
def summary(root: str, path: str) -> dict:
    with open(os.path.join(root, RESULTS, path, "summary.json")) as f:
        return json.load(f)


def cell(stats: dict, density: str) -> dict:
    return stats["by_density"][density]


def count(stats: dict, outcome: str) -> int:
    return round(stats[f"{outcome}_rate"] * stats["n"])


def num(value: float | None, digits: int = 3) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


def joined(values) -> str:
    return " / ".join(values)


def rate(stats: dict) -> str:
    return f"{stats['success_rate']:.3f}"


def table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def held_out_methods(root: str, seed: str) -> list[tuple[str, dict, dict | None]]:
    """(label, static stats, moving stats or None) of every method flown on a
    held-out seed: the default MFI, then the others at their protocol choices."""
    base = f"held_out_{seed}"
    rows = [
        (
            "**MFI, shipped gains**",
            summary(root, f"{base}/default")["methods"]["mfi"],
            summary(root, f"{base}/default_moving")["methods"]["mfi"],
        )
    ]
    tuned = summary(root, f"{base}/tuned")["methods"]
    moving = summary(root, f"{base}/tuned_moving")["methods"]
    for method in ("mfi-paper", "apf", "gf"):
        rows.append((f"{LABELS[method]}, tuned", tuned[method], moving.get(method)))
    return rows


def moving_cell(stats: dict | None) -> str:
    if stats is None:
        return "–"
    s = cell(stats, "0.1")
    collisions = count(s, "collision")
    plural = "" if collisions == 1 else "s"
    return f"{count(s, 'success')} of {s['n']} ({collisions} collision{plural})"


# --- the tables ---------------------------------------------------------------
def held_out_table(root: str, seed: str) -> str:
    header = [
        f"seed {seed}, 200 fields a density",
        "success 0.05 / 0.1 / 0.2",
        "collisions 0.05 / 0.1 / 0.2",
        "time-outs 0.2",
        "median path ratio 0.05 / 0.1 / 0.2",
        "clear line 0.05 / 0.1 / 0.2",
        "convergence 0.1 [s]",
        "moving, 30 fields",
    ]
    rows = []
    for label, stats, moving in held_out_methods(root, seed):
        cells = [cell(stats, d) for d in DENSITIES]
        rows.append(
            [
                label,
                joined(rate(c) for c in cells),
                joined(str(count(c, "collision")) for c in cells),
                str(count(cells[2], "timeout")),
                joined(num(c["median_path_ratio"]) for c in cells),
                joined(num(c["median_path_ratio_clear_line"]) for c in cells),
                num(cells[1]["median_convergence_time"], 1),
                moving_cell(moving),
            ]
        )
    return table(header, rows)


def held_out_seeds_table(root: str) -> str:
    """Every held-out seed of the current configuration, one row a method."""
    header = [
        "seed",
        "method",
        "static successes (600)",
        "collisions 0.05 / 0.1 / 0.2",
        "median path ratio 0.1",
        "clear line 0.1",
        "moving successes (30)",
    ]
    rows = []
    for seed in ("3131", "5757", "8686"):
        for label, stats, moving in held_out_methods(root, seed):
            cells = [cell(stats, d) for d in DENSITIES]
            rows.append(
                [
                    seed,
                    label.strip("*"),
                    str(sum(count(c, "success") for c in cells)),
                    joined(str(count(c, "collision")) for c in cells),
                    num(cells[1]["median_path_ratio"]),
                    num(cells[1]["median_path_ratio_clear_line"]),
                    "–" if moving is None else str(count(moving, "success")),
                ]
            )
    return table(header, rows)


def mfi_gains_table(root: str) -> str:
    """MFI's shipped gains against its tuned winner on two held-out seeds."""
    sets = {
        "shipped": {
            "6262": ("held_out_6262_default", "held_out_6262_default_moving"),
            "1212": ("held_out_1212_h_miss", "held_out_1212_h_miss_moving"),
        },
        "tuned (tune_h_miss)": {
            "6262": ("tune_h_miss/held_out", "tune_h_miss/held_out_moving"),
            "1212": ("tune_h_miss/held_out_1212", "tune_h_miss/held_out_1212_moving"),
        },
    }
    header = [
        "MFI gains",
        "seed",
        "success 0.05 / 0.1 / 0.2",
        "collisions 0.05 / 0.1 / 0.2",
        "median path ratio 0.05 / 0.1 / 0.2",
        "clear line 0.1",
        "moving, 30 fields",
    ]
    rows = []
    for gains, seeds in sets.items():
        for seed, (static, moving) in seeds.items():
            stats = summary(root, static)["methods"]["mfi"]
            cells = [cell(stats, d) for d in DENSITIES]
            rows.append(
                [
                    gains + flown_by(root, static),
                    seed,
                    joined(rate(c) for c in cells),
                    joined(str(count(c, "collision")) for c in cells),
                    joined(num(c["median_path_ratio"]) for c in cells),
                    num(cells[1]["median_path_ratio_clear_line"]),
                    moving_cell(summary(root, moving)["methods"]["mfi"]),
                ]
            )
    return table(header, rows)


CAMERA_SETS = [
    ("8484", "one forward camera, the default", "sweep_depth/heldout_8484/camera"),
    ("8484", "sphere sensor, r_s = 3 m", "sweep_depth/heldout_8484/sphere"),
    ("8484", "`rig3`: three cameras", "sweep_depth/heldout_8484/rig3"),
    ("9595", "`rig3`: three cameras", "sweep_depth/heldout_9595/rig3_d0.05"),
    ("9595", "`rig3`: three cameras", "sweep_depth/heldout_9595/rig3"),
]


def camera_table(root: str) -> str:
    header = [
        "seed",
        "sensor",
        "density",
        "success [95 % CI]",
        "collisions (of 200)",
        "median path ratio",
        "clear line (fields)",
    ]
    rows = []
    for seed, sensor, path in CAMERA_SETS:
        stats = summary(root, path)["methods"]["mfi"]
        for density, c in stats["by_density"].items():
            ci = c["success_rate_ci95"]
            rows.append(
                [
                    seed,
                    sensor + flown_by(root, path),
                    density,
                    f"{c['success_rate']:.3f} [{ci[0]:.2f}, {ci[1]:.2f}]",
                    str(count(c, "collision")),
                    num(c["median_path_ratio"]),
                    f"{num(c['median_path_ratio_clear_line'])} "
                    f"({c['clear_line_flights']})",
                ]
            )
    return table(header, rows)


def nonconvex_table(root: str) -> str:
    """`sweep --world nonconvex` on a held-out seed: one row a method, each
    cell the classes in KINDS's order, as the held-out random fields' table
    has the densities. Before the set is flown, the command that flies it."""
    if not os.path.exists(os.path.join(root, RESULTS, NONCONVEX, "summary.json")):
        return f"Not flown yet: `python benchmarks/publish.py --only {NONCONVEX}`."
    result = summary(root, NONCONVEX)
    config = result["config"]
    header = [
        f"seed {config['seed']}, {config['n']} worlds a class",
        "success " + joined(KINDS),
        "collisions (in that order)",
        "time-outs",
        "trapped",
        "median path ratio",
        "median convergence [s]",
    ]
    rows = []
    for method, stats in result["methods"].items():
        cells = [stats["by_world"][kind] for kind in KINDS]
        rows.append(
            [appearance(method)[0]]
            + [joined(rate(c) for c in cells)]
            + [joined(str(count(c, o)) for c in cells) for o in NOT_REACHED]
            + [joined(num(c["median_path_ratio"]) for c in cells)]
            + [num(stats["median_convergence_time"], 1)]
        )
    return table(header, rows)


def benchmark_worlds_table(root: str) -> str:
    """`sweep --world clutter` and `--world floorplan` (sets
    benchmark_worlds/KIND): one row a method, its flights' outcomes counted
    in each class. Before a set is flown, the command that flies it."""
    header, cells = ["method"], {}
    for kind in BENCHMARK_WORLDS:
        path = os.path.join("benchmark_worlds", kind)
        if not os.path.exists(os.path.join(root, RESULTS, path, "summary.json")):
            return f"Not flown yet: `python benchmarks/publish.py --only {path}`."
        result = summary(root, path)
        config = result["config"]
        header += [
            f"{kind} (seed {config['seed']}, {config['n']} worlds): "
            "success / collision / time-out / trapped",
            f"{kind}: median path ratio",
        ]
        for method, stats in result["methods"].items():
            c = stats["by_world"][kind]
            counts = [count(c, "success")] + [count(c, o) for o in NOT_REACHED]
            cells.setdefault(method, []).extend(
                [joined(str(n) for n in counts), num(c["median_path_ratio"])]
            )
    rows = [[appearance(method)[0], *row] for method, row in cells.items()]
    return table(header, rows)


def markdown_table(text: str) -> str:
    """The first Markdown table of a page some command wrote."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))
    end = next(
        (i for i in range(start, len(lines)) if not lines[i].startswith("|")),
        len(lines),
    )
    return "\n".join(lines[start:end])


def read(root: str, *path: str) -> str:
    with open(os.path.join(root, *path)) as f:
        return f.read()


def ablation_table(root: str) -> str:
    """One row a variant of benchmarks/ablation.py (its ablation.md has one
    a variant and density)."""
    with open(os.path.join(root, RESULTS, "ablation_7171", "ablation.json")) as f:
        cells = json.load(f)
    variants: dict[str, dict[str, dict]] = {}
    for variant, density, stats, steps in cells:
        variants.setdefault(variant, {})[density] = stats | {"steps": steps}
    header = [
        "variant (seed 7171, 100 fields a density)",
        "collisions 0.1 / 0.2",
        "median path ratio 0.1 / 0.2",
        "clear line 0.1 (fields)",
        "median steps 0.1 / 0.2",
    ]
    rows = []
    for variant, by in variants.items():
        low, high = by["0.1"], by["0.2"]
        rows.append(
            [
                variant,
                f"{count(low, 'collision')} / {count(high, 'collision')}",
                f"{num(low['median_path_ratio'])} / {num(high['median_path_ratio'])}",
                f"{num(low['median_path_ratio_clear_line'])} "
                f"({low['clear_line_flights']})",
                f"{low['steps']:.0f} / {high['steps']:.0f}",
            ]
        )
    return table(header, rows)


def robustness_table(root: str, name: str) -> str:
    """benchmarks/robustness.py's table of a set and its break points (its
    robustness.md less the method's heading)."""
    text = read(root, RESULTS, name, "robustness.md")
    return text[text.index("|") :].strip()


def readme_field_table(root: str) -> str:
    """The README's example field, bare and wrapped, as the sweep wrote it."""
    return markdown_table(read(root, RESULTS, "readme_field", "table.md"))


def fleet_tables(root: str) -> str:
    """The multi-vehicle sweeps (`mfi-drake sweep --vehicles N`), one table
    a fleet size, as the sweep writes them, each saying who flew its MFI
    where that is not today's (`flown_by`)."""
    parts = []
    for name in FLEETS:
        result = summary(root, name)
        config = result["config"]
        parts.append(
            f"**{config['vehicles']} vehicles**, seed {config['seed']}, "
            f"{config['n']} fields ({name}{flown_by(root, name)}):\n\n"
            + fleet_table(result)
        )
    return "\n\n".join(parts)


def tuning_table(root: str, name: str) -> str:
    return markdown_table(read(root, RESULTS, name, "tuning.md"))


# The paper's scenes: `mfi-drake reproduce`'s results.md, parsed.
def reproduce_results(root: str, name: str) -> tuple[dict, dict]:
    """(metrics by scenario and method label, claims by MFI label: a list of
    held or not) from a reproduce set's results.md."""
    text = read(root, RESULTS, name, "results.md")
    metrics: dict[str, dict[str, list[str]]] = {}
    for line in markdown_table(text).splitlines()[2:]:
        scenario, method, *rest = [c.strip() for c in line.strip("|").split("|")]
        metrics.setdefault(scenario, {})[method] = rest
    claims: dict[str, list[bool]] = {}
    for part in text.split("## The paper's claims, with ")[1:]:
        label = part.split(" as MFI")[0]
        claims[label] = [
            "**held**" in line
            for line in part.splitlines()
            if re.match(r"^\d+\. ", line)
        ]
    return metrics, claims


def reproduce_table(root: str) -> str:
    """The four scenes, each method's path and convergence, shipped gains
    and the protocol's choices."""
    header = ["scene", "gains"] + [f"{label}" for label in LABELS.values()]
    rows = []
    shipped, _ = reproduce_results(root, "reproduce")
    protocol, _ = reproduce_results(root, "reproduce_protocol")
    for scenario in shipped:
        for gains, metrics in (("shipped", shipped), ("protocol", protocol)):
            row = [scenario, gains]
            for label in LABELS.values():
                reached, collided, path, time, clearance, error = metrics[scenario][
                    label
                ]
                if reached == "yes":
                    row.append(f"{path}, {time}, clear {clearance}")
                elif collided == "yes":
                    row.append("collided")
                else:
                    row.append(f"stops {error} short")
            rows.append(row)
    return table(header, rows)


def claims_table(root: str) -> str:
    header = ["gains", "MFI as", "claim 1", "claim 2", "claim 3", "claim 4"]
    rows = []
    for gains, name in (
        ("shipped", "reproduce"),
        ("protocol choices", "reproduce_protocol"),
    ):
        _, claims = reproduce_results(root, name)
        for label, held in claims.items():
            rows.append(
                [gains, label] + ["held" if h else "**did not hold**" for h in held]
            )
    return table(header, rows)


def claims_held(claims: list[bool]) -> str:
    held = [str(i) for i, h in enumerate(claims, 1) if h]
    return ", ".join(held) if held else "none"


# The README's headline table.
def speed_numbers(root: str) -> dict[str, str]:
    """The throughput benchmark's numbers from its block in performance.md."""
    text = read(root, "docs", "performance.md")
    found = {
        "planar_wall": r"MFI \(Python LeafSystems\): .*?= ([\d.]+x) real time",
        "ratio": r"ratio of real-time factors MFI / C\+\+: ([\d.]+) wall",
        "flights": r"mfi, 2 workers, compiled .*?([\d.]+) flights/min",
        "cpu": r"with \S*protocol_choices.yaml:\n\s+mfi .*?x([\d.]+) GF's",
    }
    out = {}
    for key, pattern in found.items():
        match = re.search(pattern, text)
        out[key] = match.group(1) if match else "–"
    return out


def headline_table(root: str) -> str:
    rows = []
    seed = "8686"
    methods = held_out_methods(root, seed)
    rows.append(
        [
            f"Held-out random fields, success at 0.05 / 0.1 / 0.2 obstacles per m³ "
            f"(seed {seed}, 200 fields a density; MFI at its shipped gains, "
            f"the others as the tuning protocol chose them)",
            "; ".join(
                f"{label.strip('*')} " + joined(rate(cell(s, d)) for d in DENSITIES)
                for label, s, _ in methods
            ),
            "[comparison](docs/comparison.md#held-out-random-fields)",
        ]
    )
    rows.append(
        [
            "Collisions at 0.2 (of 200); with 30 % of the obstacles circling "
            "at 1 m/s (30 fields at 0.1)",
            "; ".join(
                f"{label.strip('*')} {count(cell(s, '0.2'), 'collision')}"
                for label, s, _ in methods
            )
            + "; moving: "
            + "; ".join(
                f"{label.strip('*').split(',')[0]} {moving_cell(m)}"
                for label, _, m in methods
                if m is not None
            ),
            "[comparison](docs/comparison.md#held-out-random-fields)",
        ]
    )
    rows.append(
        [
            "Median path / shortest path at 0.1 (where the straight line is clear)",
            "; ".join(
                f"{label.strip('*')} {num(cell(s, '0.1')['median_path_ratio'])} "
                f"({num(cell(s, '0.1')['median_path_ratio_clear_line'])})"
                for label, s, _ in methods
            ),
            "[comparison](docs/comparison.md#held-out-random-fields)",
        ]
    )
    for gains, name in (
        ("shipped gains", "reproduce"),
        ("each method as the tuning protocol chose it", "reproduce_protocol"),
    ):
        metrics, claims = reproduce_results(root, name)
        reached = sum(metrics[s]["MFI"][0] == "yes" for s in metrics)
        rows.append(
            [
                f"The paper's four scenes and its four claims, {gains} "
                f"(`mfi-drake reproduce`)",
                f"MFI reaches {reached} of {len(metrics)} goals "
                f"(paths {' / '.join(metrics[s]['MFI'][2] for s in metrics)}); "
                + "claims held: "
                + "; ".join(
                    f"{label} {claims_held(held)}" for label, held in claims.items()
                ),
                "[comparison](docs/comparison.md#the-papers-scenes-and-claims)",
            ]
        )
    camera: dict[str, dict] = {}  # "sensor (seed)" -> density -> stats
    for seed_, sensor, path in CAMERA_SETS:
        by = summary(root, path)["methods"]["mfi"]["by_density"]
        name = f"{sensor.split(':')[0]} (seed {seed_}{flown_by(root, path)})"
        camera.setdefault(name, {}).update(by)
    rows.append(
        [
            "Depth camera only, held-out random fields: collisions of 200 a density",
            "; ".join(
                f"{name} "
                + " / ".join(str(count(by[d], "collision")) for d in sorted(by))
                + f" at {' / '.join(sorted(by))}"
                for name, by in camera.items()
            ),
            "[depth camera](docs/depth_camera.md#random-fields)",
        ]
    )
    with open(os.path.join(root, RESULTS, "moving", "moving.json")) as f:
        moving = json.load(f)
    with open(os.path.join(root, RESULTS, "moving", "moving.md")) as f:
        # Its first line: "Written by `python benchmarks/moving.py`: seed S, ..."
        moving_seed = re.search(r"moving\.py`: seed (\d+)", f.read()).group(1)
    at_speed = {
        method: stats
        for speed, seeing, method, stats, _ in moving
        if speed == 1 and seeing == "relative, own pace"
    }
    rows.append(
        [
            f"Moving obstacles: 30 held-out fields (seed {moving_seed}), 30 % of "
            "the obstacles circling at 1 m/s, every method at its shipped gains",
            "; ".join(
                f"{LABELS[m]} {count(s, 'success')} of {s['n']}"
                for m, s in at_speed.items()
            ),
            "[dynamic scenes](docs/dynamic.md)",
        ]
    )
    speed = speed_numbers(root)
    rows.append(
        [
            "Speed (`benchmarks/throughput.py`)",
            f"planar wall {speed['planar_wall']} real time "
            f"({speed['ratio']} of the C++-only diagram's factor); sweeps "
            f"{speed['flights']} flights/min on 2 workers; MFI's CPU a flight "
            f"{speed['cpu']}× GF's (protocol choices)",
            "[performance](docs/performance.md)",
        ]
    )
    return table(["what", "result", "details"], rows)


def flown_by(root: str, path: str) -> str:
    """The note ", flown by M" where the set holding RESULTS/`path` was
    flown by M, not today's `mfi` (the manifest's `flown_by`), else ""."""
    where = os.path.normpath(os.path.join(RESULTS, path))
    for s in published_sets(root):
        held = os.path.normpath(s["path"])
        if "flown_by" in s and (where == held or where.startswith(held + os.sep)):
            return f", flown by {s['flown_by']}"
    return ""


def stale_table(root: str) -> str:
    """The published sets whose MFI is not today's `mfi` (the manifest's
    `flown_by`: flown before the default MFI changed, not yet flown again;
    `publish.py --only PATH` flies one again)."""
    stale = [s for s in published_sets(root) if "flown_by" in s]
    if not stale:
        return "None: every published set was flown by today's methods."
    groups = []
    for by in sorted({s["flown_by"] for s in stale}):
        paths = [f"`{s['path']}`" for s in stale if s["flown_by"] == by]
        groups.append(f"{len(paths)} flown by {by}: {', '.join(paths)}")
    return f"{len(stale)} sets; " + "; ".join(groups) + "."


TABLES: dict[str, Callable[[str], str]] = {
    "headline": headline_table,
    "held_out_8686": lambda root: held_out_table(root, "8686"),
    "held_out_seeds": held_out_seeds_table,
    "mfi_gains": mfi_gains_table,
    "tuning": lambda root: tuning_table(root, "tune_moving"),
    "reproduce": reproduce_table,
    "claims": claims_table,
    "ablation": ablation_table,
    "camera": camera_table,
    "robustness": lambda root: robustness_table(root, "robustness"),
    "robustness_state": lambda root: robustness_table(root, "robustness_state_h_miss"),
    "fleet": fleet_tables,
    "readme_field": readme_field_table,
    "nonconvex": nonconvex_table,
    "benchmark_worlds": benchmark_worlds_table,
    "stale": stale_table,
}


# The set a section renders, where it is one set: a note heads the section
# while its MFI is not today's (`flown_by`).
SECTION_SETS = {
    "tuning": "tune_moving",
    "ablation": "ablation_7171",
    "robustness": "robustness",
    "robustness_state": "robustness_state_h_miss",
}


def section_text(root: str, name: str) -> str:
    """Section `name`'s text: its table, headed by the note of its set's
    `flown_by` where that is given."""
    text = TABLES[name](root)
    note = flown_by(root, SECTION_SETS[name]) if name in SECTION_SETS else ""
    if note:
        text = f"*MFI here{note}: not yet flown again with its escape rule.*\n\n{text}"
    return text


def write_tables(root: str) -> list[str]:
    """Rewrites every page's sections in place; returns the pages changed."""
    changed = []
    for page in PAGES:
        before = read(root, page)
        for name in SECTION.findall(before):
            if name not in TABLES:
                raise SystemExit(f"{page}: unknown section publish:{name}")
            write_section(
                os.path.join(root, page), f"publish:{name}", section_text(root, name)
            )
        if read(root, page) != before:
            changed.append(page)
    return changed


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument(
        "--only",
        nargs="+",
        metavar="NAME",
        help="regenerate only the sets whose path (under docs/results/ or "
        "docs/) starts with NAME; default: every set",
    )
    parser.add_argument(
        "--workers", type=int, default=2, help="Dask workers of each command"
    )
    parser.add_argument(
        "--scheduler", help="address of a running Dask scheduler for sweeps and tunes"
    )
    parser.add_argument(
        "--tables-only",
        action="store_true",
        help="only rewrite the pages' tables from the committed summaries",
    )
    parser.add_argument("--root", default=ROOT, help="the repository to read and write")
    parser.add_argument(
        "--list", action="store_true", help="print the files git keeps and exit"
    )
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error(f"--workers must be at least 1, got {args.workers}")
    if args.list:
        print("\n".join(kept_files(args.root)))
        return
    if not args.tables_only:
        sets = published_sets(args.root)
        if args.only:
            prefixes = [os.path.join(RESULTS, p) for p in args.only] + [
                os.path.join("docs", p) for p in args.only
            ]
            sets = [s for s in sets if s["path"].startswith(tuple(prefixes))]
            if not sets:
                parser.error(f"--only {' '.join(args.only)} names no published set")
        regenerate(sets, args.workers, args.scheduler)
    changed = write_tables(args.root)
    print("tables rewritten: " + (", ".join(changed) if changed else "none changed"))


if __name__ == "__main__":
    main()
