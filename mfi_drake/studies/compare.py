"""The paper's comparison (§VI-A, Figs 5–9): several methods flown on one
scenario, and its reproduction on the paper's four environments with a
verdict on each of the paper's claims."""

import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed

from mfi_drake.config.scenario import Scenario
from mfi_drake.flight.fleet import check_engine
from mfi_drake.flight.methods import DEFAULT_METHODS, METHODS, Method, appearance
from mfi_drake.flight.result import Flight, outcome
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.validation import load_scenario

PAPER_SCENARIOS = ["planar_wall", "three_spheres", "tree", "sharp_corner"]
# The claims are judged with each: the default MFI and the paper's literal one.
MFI_VARIANTS = ("mfi", "mfi-paper")


def compare(
    scenario: Scenario, methods: "list[str | Callable | Method]"
) -> list[Flight]:
    """Flies `scenario` once with each method (a fleet on one integrator:
    after checking that it can fly every one)."""
    check_engine(scenario, methods)
    return [simulate(scenario, method) for method in methods]


def _number(value, unit: str) -> str:
    return "–" if value is None else f"{value:.2f} {unit}"


def fleet_numbers(m: dict) -> dict:
    """A fleet flight's table numbers over its vehicles: how many reached
    and collided with an obstacle ("k/N", "touched" added where two vehicles
    met), the total path, the last convergence (None if one never
    converged), the least clearance and the largest final error."""
    vehicles = m["vehicles"]
    n = len(vehicles)
    clearances = [v["min_clearance"] for v in vehicles]
    times = [v["convergence_time"] for v in vehicles]
    touched = ", touched" if m["min_separation"] <= 0.0 else ""
    return {
        "reached": f"{sum(v['reached'] for v in vehicles)}/{n}",
        "collided": f"{sum(v['collided'] for v in vehicles)}/{n}{touched}",
        "path_length": sum(v["path_length"] for v in vehicles),
        "convergence_time": None if None in times else max(times),
        "min_clearance": min((c for c in clearances if c is not None), default=None),
        "final_error": max(v["final_error"] for v in vehicles),
    }


def results_table(metrics: list[dict]) -> str:
    """A Markdown table of runs: scenario, method, outcome and the numbers;
    a fleet's row is over its vehicles (`fleet_numbers`), and where there is
    one a last column gives each fleet's least separation."""
    fleets = any("vehicles" in m for m in metrics)
    lines = [
        "| scenario | method | reached | collided | path length | "
        "convergence time | min clearance | final error |"
        + (" least separation |" if fleets else ""),
        "|---|---|---|---|---|---|---|---|" + ("---|" if fleets else ""),
    ]
    for m in metrics:
        yes_no = {k: "yes" if m[k] else "no" for k in ("reached", "collided")}
        row = fleet_numbers(m) if "vehicles" in m else m | yes_no
        line = (
            f"| {m['scenario']} | {appearance(m['method'])[0]} "
            f"| {row['reached']} | {row['collided']} "
            f"| {_number(row['path_length'], 'm')} "
            f"| {_number(row['convergence_time'], 's')} "
            f"| {_number(row['min_clearance'], 'm')} "
            f"| {_number(row['final_error'], 'm')} |"
        )
        if fleets:
            separation = m.get("min_separation")
            line += f" {'–' if separation is None else f'{separation:.3f} m'} |"
        lines.append(line)
    return "\n".join(lines)


# --- the paper's claims -------------------------------------------------------
Results = dict[str, dict[str, dict]]  # scenario -> method -> metrics


def _outcome(m: dict) -> str:
    return {
        "success": f"reached the goal (path {m['path_length']:.2f} m)",
        "collision": f"collided (min clearance {m['min_clearance']:.3f} m)",
        "timeout": f"stopped {m['final_error']:.2f} m short",
        "trapped": f"trapped {m['final_error']:.2f} m short",
    }[outcome(m)]


def claim_apf_trapped(results: Results, mfi: str = "mfi") -> tuple[bool, str]:
    """(1) APF stops short of the goal at the planar wall and among the spheres."""
    held, why = True, []
    for name in ("planar_wall", "three_spheres"):
        m = results[name]["apf"]
        held &= not m["reached"] and not m["collided"]
        why.append(f"{name}: APF {_outcome(m)}")
    return held, "; ".join(why)


def claim_gf_longer_at_wall(results: Results, mfi: str = "mfi") -> tuple[bool, str]:
    """(2) GF reaches the goal at the wall with a longer path than MFI."""
    gf, mfi = results["planar_wall"]["gf"], results["planar_wall"][mfi]
    held = gf["success"] and mfi["success"] and gf["path_length"] > mfi["path_length"]
    return held, f"GF {_outcome(gf)}; MFI {_outcome(mfi)}"


def claim_mfi_beats_gf_among_spheres(
    results: Results, mfi: str = "mfi"
) -> tuple[bool, str]:
    """(3) Among the spheres MFI's path is shorter and it converges sooner than GF."""
    gf, mfi = results["three_spheres"]["gf"], results["three_spheres"][mfi]
    held = (
        gf["success"]
        and mfi["success"]
        and mfi["path_length"] < gf["path_length"]
        and mfi["convergence_time"] < gf["convergence_time"]
    )
    why = [f"MFI {_outcome(mfi)}", f"GF {_outcome(gf)}"]
    for name, m in (("MFI", mfi), ("GF", gf)):
        if m["convergence_time"] is not None:
            why.append(f"{name} converged at {m['convergence_time']:.2f} s")
    return held, "; ".join(why)


def claim_mfi_tree_and_corner(results: Results, mfi: str = "mfi") -> tuple[bool, str]:
    """(4) MFI reaches the goal around the tree and the sharp corner without
    collision."""
    held, why = True, []
    for name in ("tree", "sharp_corner"):
        m = results[name][mfi]
        held &= m["success"]
        why.append(
            f"{name}: MFI {_outcome(m)}, min clearance {m['min_clearance']:.3f} m"
        )
    return held, "; ".join(why)


CLAIMS: list[tuple[str, Callable[..., tuple[bool, str]]]] = [
    (
        "APF stops short of the goal at the planar wall and among the spheres",
        claim_apf_trapped,
    ),
    (
        "GF reaches the goal at the wall with a longer path than MFI",
        claim_gf_longer_at_wall,
    ),
    (
        "Among the spheres MFI's path is shorter and it converges sooner than GF",
        claim_mfi_beats_gf_among_spheres,
    ),
    (
        "MFI reaches the goal around the tree and the sharp corner without collision",
        claim_mfi_tree_and_corner,
    ),
]


def claim_verdicts(results: Results, mfi: str = "mfi") -> list[tuple[str, bool, str]]:
    """(statement, held, the numbers why) of each paper claim, with `mfi` (a
    method name) as the paper's MFI."""
    return [(statement, *claim(results, mfi)) for statement, claim in CLAIMS]


def claim_lines(results: Results, mfi: str = "mfi") -> list[str]:
    """One Markdown line per paper claim, with `mfi` as the paper's MFI: held
    or not, and the numbers why."""
    return [
        f"{i}. {statement}: **{verdict(held)}**. {why}."
        for i, (statement, held, why) in enumerate(claim_verdicts(results, mfi), 1)
    ]


def verdict(held: bool) -> str:
    return "held" if held else "did not hold"


# Called in the process that flew a scenario with (name, scenario, flights),
# e.g. to draw its figure: flights do not travel between processes.
Draw = Callable[[str, Scenario, list[Flight]], None]


def fly_paper_scenario(
    path: str, overrides: list[tuple[str, str]], draw: Draw | None
) -> dict[str, dict]:
    """Flies the scenario file `path` with every method of the registry;
    returns the metrics by method."""
    scenario = load_scenario(path, overrides)
    flights = compare(scenario, list(DEFAULT_METHODS))
    if draw is not None:
        draw(os.path.splitext(os.path.basename(path))[0], scenario, flights)
    return {f.method: f.metrics for f in flights}


def reproduce(
    scenario_dir: str,
    progress: Callable[[str], None] = print,
    overrides: list[tuple[str, str]] = (),
    workers: int = 1,
    draw: Draw | None = None,
) -> Results:
    """Flies every paper scenario, with `overrides` layered on it (e.g. tuned
    gains), with every method of the registry, the scenarios in `workers`
    processes at once (1: in this one); returns the metrics by scenario and
    method. Every scenario is loaded here first, so that bad input is
    reported before anything flies (or is said to)."""
    paths = {
        name: os.path.join(scenario_dir, f"{name}.yaml") for name in PAPER_SCENARIOS
    }
    for path in paths.values():
        load_scenario(path, overrides)
    layered = [where for where, _ in overrides]
    progress(
        f"flying {', '.join(PAPER_SCENARIOS)} from {scenario_dir}/ with every "
        f"method, {flown_with(layered)}"
    )

    def report(name: str, metrics: dict[str, dict]) -> None:
        progress(
            f"{name}: " + ", ".join(f"{m} {outcome(x)}" for m, x in metrics.items())
        )

    results: Results = {}
    if workers == 1:
        for name, path in paths.items():
            results[name] = fly_paper_scenario(path, overrides, draw)
            report(name, results[name])
    else:
        # Spawned, not forked: a fresh interpreter per worker, whatever
        # threads this process has started.
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(workers, mp_context=context) as pool:
            futures = {
                pool.submit(fly_paper_scenario, path, list(overrides), draw): name
                for name, path in paths.items()
            }
            for future in as_completed(futures):
                results[futures[future]] = future.result()
                report(futures[future], results[futures[future]])
    return {name: results[name] for name in PAPER_SCENARIOS}


def flown_with(layered: list[str]) -> str:
    """Which gains the scenarios were flown with, for reproduce's output."""
    if layered:
        return f"with {', '.join(layered)} layered on the scenarios"
    return "with the shipped gains (the scenarios' own; no --override or --set)"


def reproduction_report(results: Results, layered: list[str] = ()) -> str:
    """results.md: the table and a verdict per claim, with the figures;
    `layered` names the overrides the scenarios were flown with."""
    metrics = [m for by_method in results.values() for m in by_method.values()]
    figures = "\n".join(f"![{name}]({name}.png)" for name in results)
    return (
        "\n\n".join(
            [
                "# The paper's §VI-A comparison, reproduced",
                "Written by `mfi-drake reproduce`: each scenario flown by "
                + ", ".join(METHODS[m].label for m in DEFAULT_METHODS)
                + " on the same vehicle, sensor and attitude chain, "
                + f"{flown_with(layered)}.",
                results_table(metrics),
                *(
                    part
                    for mfi in MFI_VARIANTS
                    for part in (
                        f"## The paper's claims, with {METHODS[mfi].label} as MFI",
                        "\n".join(claim_lines(results, mfi)),
                    )
                ),
                "## Figures",
                figures,
            ]
        )
        + "\n"
    )
