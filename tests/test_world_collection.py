"""benchmarks/world_collection.py: a folder of world files loaded (and
flown past) file by file, each in a process of its own; its counts against
a folder whose files' fates are known by construction."""

import json
import os
import shutil

import pytest

from .conftest import ROOT, load_benchmark

MODELS = os.path.join(ROOT, "tests", "data", "gazebo", "models")


@pytest.fixture
def folder(tmp_path):
    """post (a 3 m cylinder: loads and is flown past), broken (not XML:
    refused in one line), notes.txt (no world file: not in the collection)."""
    shutil.copytree(os.path.join(MODELS, "post"), tmp_path / "models" / "post")
    broken = tmp_path / "models" / "broken"
    broken.mkdir()
    (broken / "model.sdf").write_text("<sdf version='1.6'><model name='b'>")
    (tmp_path / "models" / "notes.txt").write_text("not a world")
    return tmp_path / "models"


def test_a_collection_is_counted_file_by_file(folder, tmp_path, capsys):
    out = tmp_path / "out"
    load_benchmark("world_collection").main([str(folder), "--fly", "--out", str(out)])
    with open(out / "collection.jsonl") as f:
        records = {r["file"]: r for r in map(json.loads, f)}
    assert sorted(records) == ["broken/model.sdf", "post/model.sdf"]
    post, broken = records["post/model.sdf"], records["broken/model.sdf"]
    assert post["load"] == "ok" and post["obstacles"] == 1
    assert post["flight"] == "success" and post["clearance"] > 0.0
    assert broken["load"] == "refused" and "not well-formed XML" in broken["why"]
    assert (
        "2 files: 1 loaded, 1 refused in one line, 0 died." in capsys.readouterr().out
    )
    assert (out / "collection.md").read_text().startswith("2 files: 1 loaded")


def test_a_file_over_its_time_died_and_a_bad_folder_is_one_line(folder, tmp_path):
    """--timeout too short for any process to start: every file "died",
    counted, the run goes on; a missing folder is exit 2."""
    out = tmp_path / "out"
    module = load_benchmark("world_collection")
    argv = [str(folder), "--timeout", "0.001", "--pattern", "*/model.sdf"]
    module.main([*argv, "--out", str(out)])
    with open(out / "collection.jsonl") as f:
        records = [json.loads(line) for line in f]
    assert [r["load"] for r in records] == ["died", "died"]
    assert all(r["why"] == "over 0.001 s" for r in records)
    with pytest.raises(SystemExit) as error:
        module.main([str(tmp_path / "nowhere")])
    assert error.value.code == 2
