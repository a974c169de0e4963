"""The cluster's faults, each on real processes (`test_cluster.Cluster`: a
`dask scheduler` and `dask worker`s started by their command lines): a
wrong scheduler address, a client certificate from another CA, a scheduler
without the package, workers with another version of it or other maths
sources (what the compiled engine compiles), and a flight that kills its
workers past Dask's allowed-failures. A refusal is one line, exit status 2,
before anything flies, and leaves no output folder; a flight lost mid-run
leaves the records already written whole."""

import hashlib
import json
import os
import socket
from pathlib import Path

import dask
import pytest

from mfi_drake.app.cli import main
from mfi_drake.maths import compiled
from mfi_drake.studies import cluster as study_cluster
from mfi_drake.studies import records as record_store

from .test_cluster import Cluster, _certificates, mfi_drake

distributed = pytest.importorskip("distributed")

SWEEP = ["sweep", "--n", "1", "--seed", "4711", "--methods", "mfi"]
SWEEP += ["--set", "duration: 3"]


def refusal(capsys, args: list[str], out: Path) -> str:
    """The one line of `mfi-drake sweep ARGS --out OUT`, which must exit 2
    and write nothing."""
    assert main([*args, "--out", str(out)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert not out.exists(), os.listdir(out)
    return line


def test_a_wrong_scheduler_address_is_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(study_cluster, "CONNECT_WAIT", 2.0)
    with socket.socket() as s:  # a port nothing listens at (closed again)
        s.bind(("127.0.0.1", 0))
        closed = s.getsockname()[1]
    words = {
        f"tcp://127.0.0.1:{closed}": f"nothing listens at port {closed} of 127.0.0.1",
        f"127.0.0.1:{closed}": "nothing listens",  # Dask's default: tcp
        "tcp://no-such-host.invalid:8786": "no host 'no-such-host.invalid' is known",
        "tcp://127.0.0.1:99999": "not an address: port 99999 is not one of 1 to 65535",
        "http://127.0.0.1:8786": "not an address (ValueError: unknown address scheme",
        "tcp://127.0.0.1": "not an address (ValueError: missing port number",
    }
    for address, why in words.items():
        line = refusal(capsys, [*SWEEP, "--scheduler", address], tmp_path / "o")
        assert line.startswith(f"mfi-drake: error: --scheduler = {address!r}: ")
        assert why in line, line


def test_a_port_that_never_speaks_dask_is_one_line(tmp_path, capsys, monkeypatch):
    """A socket that accepts (the kernel's backlog) and never answers: Dask's
    own handshake would wait for ever; the client gives up in CONNECT_WAIT
    (1 s: the wait is idle time, and nothing will answer)."""
    monkeypatch.setattr(study_cluster, "CONNECT_WAIT", 1.0)
    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen(8)
        address = f"tcp://127.0.0.1:{silent.getsockname()[1]}"
        line = refusal(capsys, [*SWEEP, "--scheduler", address], tmp_path / "o")
    assert f"--scheduler = {address!r}: no Dask scheduler answers within 1 s" in line


@pytest.fixture(scope="module")
def client_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("client")


def test_a_client_certificate_from_another_ca_is_one_line(tmp_path, client_dir, capsys):
    """The cluster's CA and another's: a client certificate of the other CA
    is refused by the scheduler; a client trusting the other CA refuses the
    scheduler's. Each in one line, naming the settings to mend (which side
    closes the handshake first varies: one line says both)."""
    ours, theirs = tmp_path / "ours", tmp_path / "theirs"
    ours.mkdir(), theirs.mkdir()
    secure = Cluster(tmp_path / "secure", client_dir, _certificates(ours))
    _certificates(theirs)
    config = "distributed.comm.tls"
    try:
        args = [*SWEEP, "--scheduler", secure.address]
        for ca, cert in ((ours, theirs), (theirs, theirs)):
            with dask.config.set({
                f"{config}.ca-file": str(ca / "ca.pem"),
                f"{config}.client.cert": str(cert / "cert.pem"),
                f"{config}.client.key": str(cert / "key.pem"),
            }):  # fmt: skip
                line = refusal(capsys, args, tmp_path / "o")
            assert "the TLS handshake failed: the scheduler refuses the client's " \
                "certificate, or the client the scheduler's" in line, line  # fmt: skip
            print(line)
    finally:
        secure.close()


STUB = "__version__ = {version!r}\n"
# On a process's import path: hides the installed package (its editable
# finder), as on a machine where it was never installed.
# A sitecustomize that hides mfi_drake however it is installed (editable or
# in site-packages): a first finder that refuses it.
HIDE = """\
import sys


class Hide:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] == "mfi_drake":
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)


sys.meta_path.insert(0, Hide())
"""


def stub(directory: Path, version: str, maths: str = "") -> str:
    """A PYTHONPATH whose mfi_drake is a stub of `version` (with a maths
    module of text `maths` if given)."""
    package = directory / "mfi_drake"
    (package / "maths").mkdir(parents=True)
    (package / "__init__.py").write_text(STUB.format(version=version))
    if maths:
        (package / "maths" / "fields.py").write_text(maths)
    return str(directory)


def test_a_scheduler_without_the_package_is_one_line(tmp_path, client_dir, capsys):
    (tmp_path / "hide").mkdir()
    (tmp_path / "hide" / "sitecustomize.py").write_text(HIDE)
    bare = Cluster(tmp_path / "bare", client_dir, path=str(tmp_path / "hide"))
    try:
        line = refusal(capsys, [*SWEEP, "--scheduler", bare.address], tmp_path / "o")
    finally:
        bare.close()
    import mfi_drake

    assert "the scheduler has no mfi_drake, the client mfi_drake" in line, line
    assert f"mfi_drake {mfi_drake.__version__} (maths sources " in line, line


def test_workers_with_another_version_are_one_line(tmp_path, client_dir, capsys):
    """A worker with a stub of another version, then one of the same version
    whose maths sources differ (its compiled code would too): each refused,
    the worker and both sides' versions named."""
    import mfi_drake

    mine = mfi_drake.__version__
    cluster = Cluster(tmp_path / "mixed", client_dir)
    args = [*SWEEP, "--scheduler", cluster.address]
    try:
        cluster.add_worker("old", stub(tmp_path / "old", "0.0.1"))
        line = refusal(capsys, args, tmp_path / "o")
        assert f"has mfi_drake 0.0.1 (maths sources e3b0c44298fc), the client " \
            f"mfi_drake {mine} (maths sources " in line, line  # fmt: skip
        with distributed.Client(cluster.address) as watcher:
            (address,) = watcher.scheduler_info()["workers"]
        assert f": worker {address} has " in line, line
        cluster.kill("old")
        cluster.add_worker("edited", stub(tmp_path / "edited", mine, "x = 1\n"))
        line = refusal(capsys, args, tmp_path / "o")
        assert f"has mfi_drake {mine} (maths sources " in line, line
        theirs, ours = (part.split(")")[0] for part in line.split("sources ")[1:])
        assert theirs != ours, line
    finally:
        cluster.close()
    print(line)


def test_the_probe_hashes_the_maths_as_the_compiled_cache_stamps_them(tmp_path):
    """The probe a worker runs compares the hash that stamps the compiled
    engine's cache (one function, `compiled.sources_digest`), and travels as
    code: it names no maths module, which a worker may lack."""
    import pickle

    import cloudpickle

    sent = cloudpickle.dumps(study_cluster._probe())
    assert b"mfi_drake.maths" not in sent
    assert pickle.loads(sent)()[1] == compiled._sources_stamp()[:12]
    # Oracle: SHA-256 by hand of a directory of one module (and one not).
    (tmp_path / "fields.py").write_text("x = 1\n")
    (tmp_path / "notes.txt").write_text("not a module")
    by_hand = hashlib.sha256(b"fields.py\0x = 1\n").hexdigest()
    assert compiled.sources_digest(str(tmp_path)) == by_hand


KILLER = """\
import os, signal

def field(position, velocity, obstacle_points, goal):
    os.kill(os.getpid(), signal.SIGKILL)  # the worker dies in the flight
"""


def test_a_flight_that_kills_its_workers_is_lost_in_one_line(tmp_path):
    """On a local cluster (whose nannies restart a killed worker), with
    allowed-failures 1: the killer's flight is lost in the last line, exit
    status 1, and results.jsonl (MFI's flight, flown by a first run: a
    flight sharing the killer's worker would die with it, and Dask puts
    the flights of one field where their reference path is) stays whole."""
    (tmp_path / "killer.py").write_text(KILLER)
    first = mfi_drake([*SWEEP, "--workers", "1", "--out", "out"], tmp_path)
    assert first.returncode == 0, first.stderr[-2000:]
    args = [*SWEEP[:-3], "mfi,killer:field", "--set", "duration: 3"]
    env = {"DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "1"}
    result = mfi_drake([*args, "--workers", "2", "--out", "out"], tmp_path, env)
    assert result.returncode == 1, result.stderr[-2000:]
    line = result.stderr.strip().splitlines()[-1]
    assert line.startswith("mfi-drake: not run (rerun to retry): flight-killer:field-")
    assert "it killed 2 workers, the last tcp://" in line, line
    assert "allowed-failures = 1)" in line, line
    text = (tmp_path / "out" / "results.jsonl").read_text()
    assert text.endswith("\n")
    (record,) = [json.loads(r) for r in text.splitlines()]
    assert record["method"] == "mfi" and record["outcome"] in record_store.OUTCOMES
    assert record_store.read_results(str(tmp_path / "out" / "results.jsonl")) == [
        record
    ]
    print(line)
