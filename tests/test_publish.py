"""benchmarks/publish.py: the docs' tables are what it renders from the
committed summaries, and git keeps exactly the published sets' files."""

import json
import os
import shutil
import sys

import pytest

from mfi_drake import load_scenario
from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.scenario_yaml import read_override

from .conftest import ROOT, SCENARIOS, git_tracked, load_benchmark

publish = load_benchmark("publish")


@pytest.fixture
def copy(tmp_path):
    """The pages and the summaries they are rendered from, in a temp copy."""
    shutil.copytree(os.path.join(ROOT, "docs"), tmp_path / "docs")
    shutil.copy(os.path.join(ROOT, "README.md"), tmp_path / "README.md")
    return tmp_path


def pages(root) -> dict[str, str]:
    out = {}
    for page in publish.PAGES:
        with open(os.path.join(root, page)) as f:
            out[page] = f.read()
    return out


def test_the_docs_tables_equal_what_publish_renders(copy, capsys):
    committed = pages(ROOT)
    # Every table publish.py knows is on some page, so none goes unchecked.
    used = {
        name for text in committed.values() for name in publish.SECTION.findall(text)
    }
    assert used == set(publish.TABLES)
    publish.main(["--tables-only", "--root", str(copy)])
    assert "none changed" in capsys.readouterr().out
    assert pages(copy) == committed


def test_a_stale_table_is_written_again(copy):
    readme = copy / "README.md"
    text = readme.read_text()
    begin, end = "<!-- BEGIN publish:headline -->\n", "<!-- END publish:headline -->"
    start = text.index(begin) + len(begin)
    readme.write_text(text[:start] + "| stale |\n" + text[text.index(end) :])
    publish.main(["--tables-only", "--root", str(copy)])
    assert readme.read_text() == text


def test_the_stale_list_names_each_earlier_mfi_with_its_sets(copy):
    """Sets flown by two earlier MFIs: each named with its own sets."""
    manifest = copy / publish.MANIFEST
    text = manifest.read_text().replace("flown_by = ", "#")
    for path, by in [("docs/sweep", "A"), ("docs/results/moving", "B")]:
        line = f'path = "{path}"\n'
        text = text.replace(line, line + f'flown_by = "{by}"\n', 1)
    manifest.write_text(text)
    assert publish.stale_table(str(copy)) == (
        "2 sets; 1 flown by A: `docs/sweep`; 1 flown by B: `docs/results/moving`."
    )


def test_git_keeps_exactly_the_published_files():
    kept = publish.kept_files()
    assert len(kept) == len(set(kept))
    missing = [p for p in kept if not os.path.isfile(os.path.join(ROOT, p))]
    assert not missing, missing
    tracked = set(git_tracked("docs/results", "docs/sweep")) - {publish.MANIFEST}
    under = {p for p in kept if p.startswith(("docs/results/", "docs/sweep/"))}
    assert tracked == under


def test_recorded_commands_run_on_the_requested_workers_and_scheduler():
    sweep = "mfi-drake sweep --seed 5 --workers 2 --out docs/results/x"
    argv = publish.command_argv(sweep, 4, "tcp://host:8786")
    assert argv[1:] == [
        "sweep", "--seed", "5", "--workers", "4", "--out", "docs/results/x",
        "--scheduler", "tcp://host:8786",
    ]  # fmt: skip
    assert os.path.basename(argv[0]).startswith("mfi-drake")
    # A benchmark script takes no scheduler; reproduce has no workers.
    script = publish.command_argv("python benchmarks/ablation.py --workers 2", 1, "a")
    assert script == [sys.executable, "benchmarks/ablation.py", "--workers", "1"]
    assert publish.command_argv("mfi-drake reproduce --out d", 3, "a")[1:] == [
        "reproduce", "--out", "d",
    ]  # fmt: skip
    for s in publish.published_sets():
        for command in s["commands"]:
            _, rest = publish.command_env(command)
            assert rest.split()[0] in ("mfi-drake", "python"), command


def test_a_recorded_command_may_set_its_environment_first():
    env, rest = publish.command_env("PYTHONPATH=benchmarks mfi-drake sweep --n 1")
    assert env["PYTHONPATH"] == "benchmarks" and rest == "mfi-drake sweep --n 1"
    env, rest = publish.command_env("mfi-drake sweep --set 'A=b'")
    assert rest == "mfi-drake sweep --set A=b" and env == dict(os.environ)


def test_protocol_choices_are_the_tune_winners_but_mfi_s():
    """docs/results/protocol_choices.yaml (each method as the protocol chose
    it) is tune_moving's winner file less MFI's section, whose shipped gains
    the protocol kept: a copy that must not drift from its source."""
    results = os.path.join(ROOT, "docs", "results")

    def sections(name):
        with open(os.path.join(results, name)) as f:
            return json.loads("".join(x for x in f if not x.startswith("#")))

    winners = sections(os.path.join("tune_moving", "tuned.yaml"))
    chosen = sections("protocol_choices.yaml")
    assert "navigator" in winners and "navigator" not in chosen
    assert chosen == {k: v for k, v in winners.items() if k != "navigator"}
    # And it is an override file that layers onto a scenario.
    path = os.path.join(results, "protocol_choices.yaml")
    planar_wall = os.path.join(SCENARIOS, "planar_wall.yaml")
    scenario = load_scenario(planar_wall, [read_override(path)])
    assert scenario.gf.k_g == pytest.approx(chosen["gf"]["k_g"])
    assert scenario.navigator == NavigatorParams()
