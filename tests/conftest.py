"""Shared fixtures: paths to the shipped scenarios, a YAML writer, a current
directory for a user's module, an in-process Dask client, the benchmark
scripts as modules, and the files git tracks; and where the suite's time
goes (per test file, at the end of every run, beside pytest's
--durations=20 of the slowest tests that pyproject.toml asks for)."""

import collections
import importlib.util
import os
import subprocess
import sys
import textwrap

import distributed
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENARIOS = os.path.join(ROOT, "scenarios")

# Seconds per test file (setup, call and teardown of its tests; with xdist
# the workers' reports reach the controller, which sums them).
FILE_SECONDS: collections.Counter = collections.Counter()
TIME_FILES_SHOWN = 20


def pytest_runtest_logreport(report) -> None:
    FILE_SECONDS[report.nodeid.split("::")[0]] += report.duration


def pytest_terminal_summary(terminalreporter) -> None:
    if not FILE_SECONDS:
        return
    total = sum(FILE_SECONDS.values())
    terminalreporter.section(
        f"time per test file (the longest {min(TIME_FILES_SHOWN, len(FILE_SECONDS))}"
        f" of {len(FILE_SECONDS)}; {total:.0f} s of test time in all)"
    )
    for path, seconds in FILE_SECONDS.most_common(TIME_FILES_SHOWN):
        terminalreporter.write_line(
            f"{seconds:8.1f} s {100 * seconds / total:5.1f} %  {path}"
        )


@pytest.fixture
def write_yaml(tmp_path):
    """Writes a (dedented) YAML text to a file in tmp_path; returns its path."""

    def write(text: str, name: str = "scenario.yaml") -> str:
        path = tmp_path / name
        path.write_text(textwrap.dedent(text))
        return str(path)

    return write


@pytest.fixture
def module_dir(tmp_path, monkeypatch):
    """tmp_path as the current directory, where a test writes a user's
    module; the import path is restored after, and the modules imported
    from tmp_path are forgotten. Only those: a library's module imported
    meanwhile stays (numba imports its typing declarations lazily, and
    imported again they would register every declaration twice: "cannot
    augment Function(eq) with Function(eq)" in every later compile)."""
    monkeypatch.chdir(tmp_path)
    path, modules = list(sys.path), set(sys.modules)
    yield tmp_path
    sys.path[:] = path
    for name in set(sys.modules) - modules:
        where = getattr(sys.modules[name], "__file__", None) or ""
        if os.path.realpath(where).startswith(os.path.realpath(tmp_path)):
            del sys.modules[name]


@pytest.fixture(scope="module")
def threads_client():
    """A Dask client of one in-process worker thread."""
    with distributed.Client(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0"
    ) as client:
        yield client


def load_benchmark(name: str):
    """benchmarks/NAME.py as a module (the scripts are not a package)."""
    path = os.path.join(ROOT, "benchmarks", f"{name}.py")
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def git_tracked(*paths: str) -> list[str]:
    """The files git tracks (under `paths`, if any), from the root; the
    test is skipped, with the reason printed, outside a git checkout."""
    try:
        out = subprocess.run(
            ["git", "ls-files", "-z", "--", *paths],
            cwd=ROOT,
            capture_output=True,
            check=True,
        ).stdout
    except (OSError, subprocess.CalledProcessError) as error:
        reason = f"not a git checkout ({error})"
        print(reason)
        pytest.skip(reason)
    return [p for p in out.decode().split("\0") if p]
