"""Sweeps and tuning on a real Dask cluster: a `dask scheduler` and `dask
worker` processes, each started by its own command line in a working
directory of the cluster's, and the client (`mfi-drake sweep --scheduler`)
in a directory of its own. Each worker refuses to open any file under the
client's directory (an audit hook preloaded into it), as if it ran on
another machine: what a flight needs travels in its task.

Every outcome is compared with the same sweep on a local cluster, field by
field and number by number (the simulation is deterministic; only the wall
time differs). A worker killed in the middle of a flight, a client killed
in the middle of a sweep, a cluster without workers, a user's field that
does not import on the workers and TLS with and without the certificate
are each flown or refused here. About two minutes on two shared cores."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from mfi_drake.app.cli import main
from mfi_drake.flight.simulation import simulate
from mfi_drake.studies import cluster as study_cluster
from mfi_drake.studies import records as record_store
from mfi_drake.world.meshes import cells_mesh, write_obj
from mfi_drake.world.validation import load_scenario

from .test_methods import USER_MODULE

distributed = pytest.importorskip("distributed")

DASK = os.path.join(os.path.dirname(sys.executable), "dask")
# The checkout under test, on every process's import path (the package may
# be installed from another).
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# A small seeded sweep: 2 fields of 20 obstacles, MFI and a user's field
# (shipped to the workers), 3 s flights.
SWEEP = ["sweep", "--n", "2", "--seed", "4711", "--density", "0.1"]
SWEEP += ["--methods", "mfi,my_nav:field", "--set", "duration: 3"]
FLIGHTS = 4
GUARD = textwrap.dedent(
    """
    # Preloaded into each worker: no file under the client's directory opens.
    import os, sys

    CLIENT = os.environ["MFI_CLIENT_DIR"]

    def refuse(event, args):
        if event == "open" and isinstance(args[0], (str, bytes, os.PathLike)):
            path = os.path.abspath(os.fsdecode(args[0]))
            if path == CLIENT or path.startswith(CLIENT + os.sep):
                raise PermissionError(f"a worker opened the client's file {path}")

    sys.addaudithook(refuse)
    """
)


class Cluster:
    """A scheduler and workers, each its own process, in `root`, importing
    this checkout (or what `path`, a PYTHONPATH, holds: `path` for the
    scheduler, add_worker's for a worker)."""

    def __init__(
        self, root: Path, client_dir: Path, tls: list[str] = (), path: str = ROOT
    ):
        self.root, self.tls = root, list(tls)
        root.mkdir(parents=True, exist_ok=True)
        (root / "guard.py").write_text(GUARD)
        self.env = os.environ | {"MFI_CLIENT_DIR": str(client_dir), "PYTHONPATH": ROOT}
        self.file = root / "scheduler.json"
        self.workers: dict[str, subprocess.Popen] = {}
        self.scheduler = self._start(
            "scheduler",
            [DASK, "scheduler", "--host", "127.0.0.1", "--port", "0"]
            + ["--dashboard-address", ":0", "--scheduler-file", str(self.file)]
            + (["--protocol", "tls"] if tls else [])
            + self.tls,
            path,
        )
        deadline = time.monotonic() + 60
        while not self.file.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        self.address = json.loads(self.file.read_text())["address"]

    def _start(self, name: str, command: list[str], path: str) -> subprocess.Popen:
        log = open(self.root / f"{name}.log", "w")  # noqa: SIM115 (closed by the OS)
        return subprocess.Popen(
            command, cwd=self.root, env=self.env | {"PYTHONPATH": path},
            stdout=log, stderr=subprocess.STDOUT,
        )  # fmt: skip

    def add_worker(self, name: str, path: str = ROOT) -> None:
        self.workers[name] = self._start(
            name,
            [DASK, "worker", "--scheduler-file", str(self.file), "--name", name]
            + [
                "--nthreads",
                "1",
                "--no-nanny",
                "--preload",
                str(self.root / "guard.py"),
            ]
            + ["--local-directory", str(self.root / name), *self.tls],
            path,
        )

    def kill(self, name: str) -> None:
        self.workers[name].send_signal(signal.SIGKILL)
        self.workers[name].wait()

    def close(self) -> None:
        # Killed, not terminated: on SIGTERM a Dask worker whose scheduler is
        # going too retries for ~20 s, which cost each module 40 s of CI.
        for process in [*self.workers.values(), self.scheduler]:
            process.kill()
        for process in [*self.workers.values(), self.scheduler]:
            process.wait()


def mfi_drake(args: list[str], cwd: Path, env: dict | None = None, wait=True):
    """The command line, in a process of its own (the client)."""
    command = [sys.executable, "-m", "mfi_drake.app.cli", *args]
    environment = os.environ | {"PYTHONPATH": ROOT} | (env or {})
    if not wait:
        return subprocess.Popen(
            command, cwd=cwd, env=environment, stdout=subprocess.PIPE, text=True,
            stderr=subprocess.PIPE,
        )  # fmt: skip
    return subprocess.run(
        command, cwd=cwd, env=environment, capture_output=True, text=True, timeout=600
    )


def flights(out: Path) -> dict[tuple, dict]:
    """results.jsonl by (method, field), without the wall time; each once."""
    records = record_store.read_results(str(out / "results.jsonl"))
    by_flight = {(r["method"], r["scenario"]): r for r in records}
    assert len(by_flight) == len(records), "a flight recorded twice"
    for r in records:
        del r["wall_time"]
    return by_flight


@pytest.fixture(scope="module")
def client_dir(tmp_path_factory) -> Path:
    """The client's working directory: the user's module and the outputs."""
    directory = tmp_path_factory.mktemp("client")
    (directory / "my_nav.py").write_text(USER_MODULE)
    return directory


@pytest.fixture(scope="module")
def local(client_dir) -> dict[tuple, dict]:
    """The sweep on a local cluster of two worker processes."""
    result = mfi_drake([*SWEEP, "--workers", "2", "--out", "local"], client_dir)
    assert result.returncode == 0, result.stderr[-2000:]
    records = flights(client_dir / "local")
    assert len(records) == FLIGHTS
    return records


@pytest.fixture(scope="module")
def cluster(tmp_path_factory, client_dir):
    cluster = Cluster(tmp_path_factory.mktemp("cluster"), client_dir)
    for name in ("worker-a", "worker-b"):
        cluster.add_worker(name)
    yield cluster
    cluster.close()


def test_a_remote_sweep_flies_what_the_local_one_does(cluster, client_dir, local):
    start = time.monotonic()
    result = mfi_drake([*SWEEP, "--scheduler", cluster.address, "--out", "remote"],
                       client_dir)  # fmt: skip
    assert result.returncode == 0, result.stderr[-2000:]
    seconds = time.monotonic() - start
    assert flights(client_dir / "remote") == local
    print(f"{FLIGHTS} flights in {seconds:.0f} s on two remote workers")
    # The out folder holds the results only: no mesh files; the cluster's
    # directory none either.
    out = client_dir / "remote"
    assert set(os.listdir(out)) <= {
        "results.jsonl", "summary.json", "table.md", "sweep.png", "failures"
    }  # fmt: skip
    for directory in (out, cluster.root):
        assert not [f for _, _, files in os.walk(directory) for f in files
                    if f.endswith(".obj")]  # fmt: skip
    # A failure replay is one file that flies by itself, anywhere.
    replay = sorted((out / "failures").glob("*_mfi_field_*.yaml"))[0]
    alone = cluster.root / "replay.yaml"
    alone.write_text(replay.read_text())
    flight = simulate(load_scenario(str(alone)), "mfi")
    name = replay.stem.rpartition("_mfi_")[2]
    assert flight.metrics["path_length"] == pytest.approx(
        local[("mfi", name)]["path_length"], rel=1e-9
    )


def test_a_killed_worker_and_a_killed_client_lose_nothing(cluster, client_dir, local):
    """A worker killed in the middle of a flight (another joins), then the
    client killed once a flight is recorded: the rerun flies the rest, and
    every flight is recorded once, with the local cluster's outcome."""
    out = client_dir / "killed"
    args = [*SWEEP, "--scheduler", cluster.address, "--out", "killed"]
    running = mfi_drake(args, client_dir, wait=False)
    with distributed.Client(cluster.address, timeout=30) as watcher:
        victim = flight = None
        deadline = time.monotonic() + 300
        while victim is None and time.monotonic() < deadline:
            time.sleep(0.1)
            names = {
                w["name"]: a for a, w in watcher.scheduler_info()["workers"].items()
            }
            busy = watcher.processing()
            for name in cluster.workers:
                keys = [k for k in busy.get(names.get(name), ()) if "flight" in str(k)]
                if keys and cluster.workers[name].poll() is None:
                    victim, flight = name, str(keys[0])
                    break
        assert victim is not None, "no flight ever ran"
        cluster.kill(victim)  # in the middle of `flight`
        cluster.add_worker(f"{victim}-replacement")  # workers come and go
    deadline = time.monotonic() + 300
    results = out / "results.jsonl"
    while time.monotonic() < deadline and not (
        results.exists() and results.stat().st_size
    ):
        time.sleep(0.005)
    running.send_signal(signal.SIGKILL)
    running.wait()
    done = len(flights(out))
    # Usually mid-sweep; the last flights of 3 s can land within the same few
    # ms, and then the rerun must find them all done and fly nothing.
    assert 0 < done <= FLIGHTS
    result = mfi_drake(args, client_dir)
    assert result.returncode == 0, result.stderr[-2000:]
    assert f"flew {FLIGHTS - done}, found {done} done" in result.stdout
    assert flights(out) == local
    print(f"killed {victim} flying {flight}, then the client after {done} records")


def test_tune_on_the_cluster(cluster, client_dir):
    args = ["tune", "--methods", "gf", "--candidates", "3", "--n", "1"]
    args += ["--density", "0.05", "--scheduler", cluster.address, "--out", "tune"]
    result = mfi_drake(args, client_dir)
    assert result.returncode == 0, result.stderr[-2000:]
    records = record_store.read_results(str(client_dir / "tune" / "tune.jsonl"))
    assert sorted(r["candidate"] for r in records) == [0, 1, 2]
    assert (client_dir / "tune" / "tuned.yaml").read_text().count("gf") >= 1


WORLD = """\
<?xml version="1.0"?>
<sdf version="1.9">
  <model name="shed">
    <static>true</static>
    <pose>5 2.5 2 0 0 0</pose>
    <link name="link">
      <collision name="roof"><geometry><box><size>4 1 0.2</size></box></geometry>
      </collision>
      <collision name="walls"><geometry><mesh><uri>u.obj</uri></mesh></geometry>
      </collision>
    </link>
  </model>
</sdf>
"""


def test_a_sweep_on_a_world_flies_where_the_world_file_is_not(cluster, client_dir):
    """Random fields with a world layered on them (`--set 'world: ...'`, an
    SDFormat file holding a box and a non-convex mesh, in the client's
    directory): the workers, which cannot open it, fly its obstacles."""
    cells = np.zeros((3, 2, 1), bool)
    cells[0] = cells[2] = True
    cells[:, 0] = True
    write_obj(str(client_dir / "u.obj"), *cells_mesh(cells, [0.5, 0.5, 1.0]))
    (client_dir / "shed.sdf").write_text(WORLD)
    args = ["sweep", "--n", "1", "--seed", "4711", "--methods", "mfi"]
    args += ["--set", "world: shed.sdf", "--set", "duration: 3"]
    result = mfi_drake([*args, "--scheduler", cluster.address, "--out", "world"],
                       client_dir)  # fmt: skip
    assert result.returncode == 0, result.stderr[-2000:]
    (record,) = record_store.read_results(str(client_dir / "world" / "results.jsonl"))
    assert record["outcome"] != "error", record
    bare = mfi_drake([*args[:-4], "--set", "duration: 3", "--workers", "1",
                      "--out", "bare"], client_dir)  # fmt: skip
    assert bare.returncode == 0, bare.stderr[-2000:]
    (alone,) = record_store.read_results(str(client_dir / "bare" / "results.jsonl"))
    assert record["obstacles"] >= alone["obstacles"] + 3  # the roof, 2+ pieces


def test_a_user_field_that_does_not_import_on_a_worker_is_one_line(cluster, client_dir):
    # It imports on the client, whose directory holds its data file; the
    # workers get the module but cannot read the client's file.
    (client_dir / "gains.txt").write_text("1.0\n")
    (client_dir / "needs_data.py").write_text(
        "import os\n"
        "with open(os.path.join(os.path.dirname(os.path.abspath(__file__)),"
        " 'gains.txt')) as f:\n"
        "    GAIN = float(f.read())\n"
        "def field(position, velocity, obstacle_points, goal):\n"
        "    return GAIN * (goal - position)\n"
    )
    args = ["sweep", "--n", "1", "--methods", "needs_data:field"]
    args += ["--scheduler", cluster.address, "--out", "needs_data"]
    result = mfi_drake(args, client_dir)
    assert result.returncode == 2
    (line,) = result.stderr.strip().splitlines()
    assert "'needs_data'" in line and "on worker tcp://" in line, line
    assert not record_store.read_results(
        str(client_dir / "needs_data" / "results.jsonl")
    )


def test_a_cluster_without_workers_is_one_line(
    tmp_path, client_dir, monkeypatch, capsys
):
    """At the start (sweep and tune), and when the last worker dies."""
    empty = Cluster(tmp_path / "empty", client_dir)
    # Short: each wait is idle time, and no worker can join (1 s a wait,
    # three of them).
    monkeypatch.setattr(study_cluster, "WORKER_WAIT", 1.0)
    try:
        for command in (
            ["sweep", "--n", "1"],
            ["tune", "--methods", "gf", "--n", "1", "--held-out-seed", "9"],
        ):
            args = [
                *command,
                "--scheduler",
                empty.address,
                "--out",
                str(tmp_path / "o"),
            ]
            assert main(args) == 2
            (line,) = capsys.readouterr().err.strip().splitlines()
            assert "has no workers: none joined within 1 s" in line, line
        empty.add_worker("lonely")

        def kill_when_napping():
            with distributed.Client(empty.address, timeout=30) as watcher:
                while not any(watcher.processing().values()):
                    time.sleep(0.1)
            empty.kill("lonely")

        with distributed.Client(empty.address, timeout=30) as client:
            client.wait_for_workers(1, timeout=60)
            threading.Thread(target=kill_when_napping).start()
            nap = study_cluster.Task("nap", time.sleep, (120,))
            with pytest.raises(
                study_cluster.ClusterError, match="all left, and none joined"
            ):
                study_cluster.run_tasks(client, [("nap", nap)], lambda *_: None)
    finally:
        empty.close()


def _certificates(directory: Path) -> list[str]:
    """A self-signed CA and a certificate it signs (one for every role), by
    the openssl command line; Dask's --tls-* options of them."""

    def openssl(*args):
        subprocess.run(["openssl", *args], cwd=directory, check=True,
                       capture_output=True)  # fmt: skip

    openssl(
        "req",
        "-x509",
        "-newkey",
        "rsa:2048",
        "-nodes",
        "-days",
        "1",
        "-keyout",
        "ca.key",
        "-out",
        "ca.pem",
        "-subj",
        "/CN=mfi-drake test CA",
    )
    openssl(
        "req",
        "-newkey",
        "rsa:2048",
        "-nodes",
        "-keyout",
        "key.pem",
        "-out",
        "cert.csr",
        "-subj",
        "/CN=localhost",
    )
    (directory / "san.cnf").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
    openssl("x509", "-req", "-in", "cert.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
            "-CAcreateserial", "-days", "1", "-out", "cert.pem",
            "-extfile", "san.cnf")  # fmt: skip
    return [f"--tls-ca-file={directory / 'ca.pem'}",
            f"--tls-cert={directory / 'cert.pem'}",
            f"--tls-key={directory / 'key.pem'}"]  # fmt: skip


def test_tls_flies_with_the_certificate_and_refuses_without(
    tmp_path, client_dir, local
):
    (tmp_path / "certs").mkdir()
    tls = _certificates(tmp_path / "certs")
    secure = Cluster(tmp_path / "secure", client_dir, tls)
    try:
        assert secure.address.startswith("tls://")
        secure.add_worker("worker-tls")
        certs = tmp_path / "certs"
        env = {  # Dask's own configuration, from the environment
            "DASK_DISTRIBUTED__COMM__TLS__CA_FILE": str(certs / "ca.pem"),
            "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT": str(certs / "cert.pem"),
            "DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY": str(certs / "key.pem"),
        }
        args = [*SWEEP, "--n", "1", "--scheduler", secure.address, "--out", "tls"]
        result = mfi_drake(args, client_dir, env)
        assert result.returncode == 0, result.stderr[-2000:]
        first = {k: r for k, r in local.items() if r["index"] == 0}  # --n 1
        assert flights(client_dir / "tls") == first and len(first) == 2
        refused = mfi_drake([*args[:-1], "refused"], client_dir)
        assert refused.returncode == 2
        (line,) = refused.stderr.strip().splitlines()
        assert "--scheduler" in line and "without a certificate" in line, line
        print(line)
        assert not (client_dir / "refused" / "results.jsonl").exists()
    finally:
        secure.close()
