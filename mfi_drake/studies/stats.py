"""A sweep's statistics: rates with 95 % Wilson intervals, the median path
ratio with a distribution-free interval (`group_stats`), and the Markdown
table of a summary (`summary_table`), by density or by world class."""

import math

import numpy as np

from mfi_drake.studies.records import OUTCOMES

Z_95 = 1.959964  # two-sided 95 % normal quantile


# --- statistics -----------------------------------------------------------------
def wilson_interval(k: int, n: int, z: float = Z_95) -> list[float] | None:
    """Wilson score interval of a binomial proportion k/n."""
    if n == 0:
        return None
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    # min/max: at k = 0 or n rounding may put the end a hair inside p.
    return [max(0.0, min(p, centre - half)), min(1.0, max(p, centre + half))]


def median_interval(values, z: float = Z_95) -> list[float] | None:
    """Distribution-free ~95 % interval of the median: the order statistics of
    ranks n/2 ∓ z√n/2 (normal approximation of the binomial ranks)."""
    x = np.sort(np.asarray(values, float))
    n = len(x)
    if n == 0:
        return None
    lo = max(1, math.floor(n / 2 - z * math.sqrt(n) / 2))
    hi = min(n, math.ceil(1 + n / 2 + z * math.sqrt(n) / 2))
    return [float(x[lo - 1]), float(x[hi - 1])]


def _median(values) -> float | None:
    return float(np.median(values)) if len(values) else None


def group_stats(records: list[dict]) -> dict:
    """Rates with intervals and the path-ratio and convergence statistics."""
    n = len(records)
    out: dict = {"n": n}
    for kind in OUTCOMES:
        k = sum(r["outcome"] == kind for r in records)
        out[f"{kind}_rate"] = k / n if n else None
        out[f"{kind}_rate_ci95"] = wilson_interval(k, n)
    ok = [r for r in records if r["outcome"] == "success"]
    ratios = [r["path_ratio"] for r in ok if r["path_ratio"] is not None]
    out["median_path_ratio"] = _median(ratios)
    out["median_path_ratio_ci95"] = median_interval(ratios)
    out["p90_path_ratio"] = float(np.percentile(ratios, 90)) if ratios else None
    out["median_convergence_time"] = _median([r["convergence_time"] for r in ok])
    # Fields whose straight start–goal line is clear of the grown obstacles:
    # there the shortest path is the line, so any detour is the method's.
    clear = [
        r["path_ratio"]
        for r in ok
        if r["path_ratio"] is not None and r["blocked_fraction"] == 0.0
    ]
    out["clear_line_flights"] = len(clear)
    out["median_path_ratio_clear_line"] = _median(clear)
    refs = [
        r["reference_length"] / r["straight_length"]
        for r in records
        if r["reference_length"]
    ]
    out["median_reference_detour"] = _median(refs)
    blocked = [r["blocked_fraction"] for r in records]
    out["line_blocked_fields"] = float(np.mean(np.array(blocked) > 0)) if n else None
    out["mean_blocked_fraction"] = float(np.mean(blocked)) if n else None
    return out


def rate_cell(stats: dict, outcome: str) -> str:
    """ "rate [low, high]" of an outcome (95 % Wilson interval), "–" if none."""
    rate, ci = stats[f"{outcome}_rate"], stats[f"{outcome}_rate_ci95"]
    if rate is None:
        return "–"
    return f"{rate:.2f} [{ci[0]:.2f}, {ci[1]:.2f}]"


def _num(value, digits: int = 2) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


def summary_groups(pooled: dict) -> tuple[str, dict]:
    """(the column's heading, stats by group) of a method's summary: by
    density for the random fields, by class for generated worlds."""
    if "by_world" in pooled:
        return "world", pooled["by_world"]
    return "density [1/m³]", pooled["by_density"]


def summary_table(summary: dict) -> str:
    """A Markdown table: one row per method and density (or world class).
    Trapped flights (`flight.result.outcome`) have a column in a table of
    generated worlds, and in any other where some flight was trapped."""
    rows = [
        (method, *summary_groups(pooled))
        for method, pooled in summary["methods"].items()
    ]
    heading = rows[0][1] if rows else "density [1/m³]"
    trapped = heading == "world" or any(
        s.get("trapped_rate") for _, _, groups in rows for s in groups.values()
    )
    outcomes = ["success", "collision", "timeout"] + ["trapped"] * trapped
    lines = [
        f"| method | {heading} | flights | "
        + " | ".join(f"{o} [95% CI]" for o in outcomes)
        + " | median path ratio [95% CI] | p90 path ratio "
        "| median path ratio, clear line (fields) | median convergence time [s] |",
        "|---" * (7 + len(outcomes)) + "|",
    ]
    for method, _, groups in rows:
        for group, s in groups.items():
            ci = s["median_path_ratio_ci95"]
            median = _num(s["median_path_ratio"], 3)
            if ci:
                median += f" [{ci[0]:.3f}, {ci[1]:.3f}]"
            errors = (
                f" ({s['error_rate'] * s['n']:.0f} errors)" if s["error_rate"] else ""
            )
            lines.append(
                f"| {method} | {group} | {s['n']}{errors} | "
                + " | ".join(rate_cell(s, o) for o in outcomes)
                + f" | {median} "
                f"| {_num(s['p90_path_ratio'], 3)} "
                f"| {_num(s.get('median_path_ratio_clear_line'), 3)} "
                f"({s.get('clear_line_flights', 0)}) "
                f"| {_num(s['median_convergence_time'], 1)} |"
            )
    return "\n".join(lines)
