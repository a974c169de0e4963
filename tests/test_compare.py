"""The comparison commands: one comparison end to end, the JSON contract, the
claim verdicts, reproduce's files, the Meshcat animation and bad input."""

import json
import os

import pytest

from mfi_drake.app.animation import titled_page
from mfi_drake.app.cli import main
from mfi_drake.studies.compare import (
    CLAIMS,
    PAPER_SCENARIOS,
    claim_lines,
    flown_with,
    results_table,
)

from .conftest import SCENARIOS

WALL = os.path.join(SCENARIOS, "planar_wall.yaml")


def test_compare_json_on_the_wall_gives_the_paper_outcomes(tmp_path, capsys):
    args = ["compare", WALL, "--methods", "mfi,apf", "--json", "--out", str(tmp_path)]
    assert main(args) == 1  # APF does not reach the goal
    out = json.loads(capsys.readouterr().out)
    assert out["scenario"] == "planar_wall"
    assert [r["method"] for r in out["results"]] == ["mfi", "apf"]
    mfi, apf = out["results"]
    assert mfi["success"] and mfi["min_clearance"] > 0.0
    # APF is trapped in front of the wall (its face is 4.1 m from the goal):
    # short of the goal, but no collision
    assert not apf["reached"] and not apf["collided"]
    assert 4.1 < apf["final_error"] < 6.0
    for result in out["results"]:  # each entry is the run command's JSON
        assert {"scenario", "method", "reached", "collided", "path_length"} <= set(
            result
        )
    assert (tmp_path / "compare.png").stat().st_size > 10_000


def test_run_json_carries_the_method_and_html_is_written(tmp_path, capsys):
    html = tmp_path / "flight.html"
    args = ["run", WALL, "--method", "gf", "--json", "--out", str(tmp_path)]
    # GF, with the shipped gains, times out at the wall: exit status 1, and
    # every output is written all the same.
    assert main([*args, "--html", str(html)]) == 1
    metrics = json.loads(capsys.readouterr().out)
    assert metrics["method"] == "gf" and metrics["outcome"] == "timeout"
    assert (tmp_path / "trajectory.png").stat().st_size > 10_000
    text = html.read_text()
    assert text.lstrip().lower().startswith("<!doctype html") or "<html" in text[:500]
    assert "set_animation" in text or len(text) > 100_000
    assert "<title>planar_wall: GF (mfi-drake)</title>" in text
    assert text.count('<div id="legend"') == 1 and "GF (failed)</div>" in text
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".tmp-")]


def test_the_page_title_is_the_text_given_escaped():
    page = "<html><head><title>Drake MeshCat</title></head><body>\n<p>x</p>"
    titled = titled_page(page, r"a\1 <b> & c", '<div id="legend">L</div>')
    assert titled == (
        "<html><head><title>a\\1 &lt;b&gt; &amp; c</title></head>"
        '<body><div id="legend">L</div>\n<p>x</p>'
    )
    with pytest.raises(RuntimeError, match="no <title>"):
        titled_page("<html><body></body>", "t", "")


@pytest.mark.parametrize("value", ["mfi,foo", "mfi,mfi", "", "MFI"])
def test_bad_methods_exit_2_with_one_line(value, capsys):
    assert main(["compare", WALL, "--methods", value]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--methods" in err and repr(value) in err


def test_html_must_name_an_html_file(tmp_path, capsys):
    assert main(["compare", WALL, "--html", str(tmp_path / "a.png")]) == 2
    assert "--html" in capsys.readouterr().err


def metrics(scenario, method, success=True, collided=False, path=10.0, time=12.0):
    return {
        "scenario": scenario,
        "method": method,
        "success": success,
        "reached": success,
        "collided": collided,
        "path_length": path,
        "convergence_time": time if success else None,
        "min_clearance": -0.1 if collided else 0.2,
        "final_error": 0.0 if success else 4.0,
    }


def paper_results(**changes):
    """Metrics in which every claim holds, then `changes` applied."""
    results = {
        name: {m: metrics(name, m) for m in ("mfi", "apf", "gf")}
        for name in PAPER_SCENARIOS
    }
    for name in ("planar_wall", "three_spheres"):
        results[name]["apf"] = metrics(name, "apf", success=False)
    results["planar_wall"]["gf"] = metrics("planar_wall", "gf", path=11.0)
    results["three_spheres"]["gf"] = metrics("three_spheres", "gf", path=11, time=13)
    for key, value in changes.items():
        name, method = key.split("__")
        results[name][method] = value
    return results


def verdicts(results):
    return [claim(results)[0] for _, claim in CLAIMS]


def test_claims_hold_on_paper_like_numbers_and_fail_one_at_a_time():
    assert verdicts(paper_results()) == [True] * 4
    collided = metrics("planar_wall", "apf", success=False, collided=True)
    assert verdicts(paper_results(planar_wall__apf=collided))[0] is False
    short_gf = metrics("planar_wall", "gf", path=9.0)
    assert verdicts(paper_results(planar_wall__gf=short_gf))[1] is False
    quick_gf = metrics("three_spheres", "gf", path=11.0, time=11.0)
    assert verdicts(paper_results(three_spheres__gf=quick_gf)) == [
        True,
        True,
        False,
        True,
    ]
    lost_mfi = metrics("tree", "mfi", success=False)
    assert verdicts(paper_results(tree__mfi=lost_mfi))[3] is False
    lines = claim_lines(paper_results(three_spheres__gf=quick_gf))
    assert len(lines) == 4 and "**did not hold**" in lines[2]
    assert "11.00 s" in lines[2]  # the numbers say why


def test_results_table_has_a_row_per_run():
    rows = results_table([metrics("a", "mfi"), metrics("a", "apf", success=False)])
    lines = rows.splitlines()
    assert len(lines) == 4 and "| a | APF | no | no |" in lines[3]
    assert "12.00 s" in lines[2] and "–" in lines[3]


def test_a_fleets_row_is_over_its_vehicles():
    one = {"reached": True, "collided": False, "path_length": 5.0}
    one |= {"convergence_time": 7.0, "min_clearance": None, "final_error": 0.01}
    two = {"reached": False, "collided": True, "path_length": 3.0}
    two |= {"convergence_time": None, "min_clearance": -0.01, "final_error": 2.0}
    fleet = metrics("f", "mfi") | {"vehicles": [one, two], "min_separation": 0.1}
    lines = results_table([metrics("a", "gf"), fleet]).splitlines()
    assert lines[0].endswith("| least separation |")
    assert lines[2].endswith("| – |")  # a single vehicle has none
    # By hand: 1 of 2 reached and collided, 5 + 3 m, one never converged.
    assert lines[3] == (
        "| f | MFI | 1/2 | 1/2 | 8.00 m | – | -0.01 m | 2.00 m | 0.100 m |"
    )
    fleet["min_separation"] = -0.02  # two of its vehicles met
    assert "| 1/2 | 1/2, touched |" in results_table([fleet])


def test_reproduce_writes_every_figure_and_results(tmp_path, capsys):
    # The paper's scenarios, cut to 0.5 s: the files and what is printed, not
    # the outcomes; two processes fly them.
    out = tmp_path / "out"
    args = ["reproduce", "--out", str(out), "--workers", "2"]
    assert main([*args, "--scenarios", SCENARIOS, "--set", "duration: 0.5"]) == 0
    for name in PAPER_SCENARIOS:
        assert (out / f"{name}.png").stat().st_size > 10_000
    text = (out / "results.md").read_text()
    for label in ("MFI", "MFI (paper)", "APF", "GF"):
        assert text.count(f"| {label} |") == len(PAPER_SCENARIOS)
    assert text.count("| planar_wall |") == 4  # the default methods'
    # Four claims, judged with the default MFI and with the paper's; in 0.5 s
    # nothing reaches its goal, so only claim 1 (APF stops short) can hold.
    assert text.count("did not hold") + text.count("**held**") == 8
    assert "with --set 'duration: 0.5' layered on the scenarios" in text
    printed = capsys.readouterr().out.splitlines()
    assert "with --set 'duration: 0.5' layered on the scenarios" in printed[0]
    assert sorted(line.split(":")[0] for line in printed[1:5]) == sorted(
        PAPER_SCENARIOS
    )
    verdicts = [line for line in printed if line.startswith("  ")]
    assert len(verdicts) == 8 and all(
        line.endswith("did not hold") for i, line in enumerate(verdicts) if i % 4
    )


def test_reproduce_names_the_gains_and_refuses_bad_workers(tmp_path, capsys):
    assert flown_with([]).startswith("with the shipped gains")
    assert flown_with(["--override t.yaml", "--set 'x: 1'"]) == (
        "with --override t.yaml, --set 'x: 1' layered on the scenarios"
    )
    for workers in ("0", "5"):
        assert main(["reproduce", "--workers", workers, "--out", str(tmp_path)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"--workers = {workers}: must be 1 to 4" in err
    assert not any(tmp_path.iterdir())
