"""Running a study's tasks on a Dask cluster, local or remote: `dask_client`
(the client's own modules of MODULE:NAME methods shipped to the workers),
`run_tasks` (each `Task` once, its result handed on as it finishes, a lost
one reported) and the `Progress` bar; `ClusterError` for what the user
must fix."""

import contextlib
import logging
import os
import sys
import time
import types
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

from mfi_drake.flight.methods import METHOD_NAMES, MethodError, import_field
from mfi_drake.maths.compiled import sources_digest

# What the local workers' fork server imports once (`dask_client`): the
# sweep's module, whose tasks every study runs (Drake, the simulation, the
# reference path), named here without importing it.
PRELOAD = ["distributed", "mfi_drake.studies.sweep"]


# --- the run ----------------------------------------------------------------------
class Progress:
    """A text progress bar on stderr (a line per 10 % when not a terminal)."""

    def __init__(self, total: int, stream=None):
        # sys.stderr when called, not when defined: a test may swap it.
        stream = stream or sys.stderr
        self.total, self.done, self.stream = total, 0, stream
        self.start = time.monotonic()
        self._tty = stream.isatty()
        self._shown = -1

    def step(self, note: str = "") -> None:
        self.done += 1
        tenth = 10 * self.done // max(self.total, 1)
        if not self._tty and tenth == self._shown and self.done < self.total:
            return
        self._shown = tenth
        elapsed = time.monotonic() - self.start
        eta = elapsed / self.done * (self.total - self.done)
        filled = 30 * self.done // max(self.total, 1)
        line = (
            f"[{'#' * filled}{'.' * (30 - filled)}] {self.done}/{self.total} flights, "
            f"{elapsed:.0f} s, ~{eta:.0f} s left {note}"
        )
        end = "\r" if self._tty and self.done < self.total else "\n"
        self.stream.write(("\r" if self._tty else "") + line + end)
        self.stream.flush()


class ClusterError(RuntimeError):
    """The cluster cannot fly the tasks (unreachable or refused, no workers,
    a user's field that a worker cannot import); one line for the user."""


def require_dask() -> None:
    """Raises ClusterError, before anything is flown, where Dask distributed
    (the `sweep` extra) is not installed."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise ClusterError(
            "sweep and tune need Dask distributed: pip install 'mfi_drake[sweep]'"
        ) from None


WORKER_WAIT = 60.0  # s a run waits for a worker, at its start or when all left
CONNECT_WAIT = 10.0  # s the client tries to reach a scheduler


def _one_line(e: BaseException) -> str:
    return f"{type(e).__name__}: {' '.join(str(e).split())}"[:300]


def _unreachable(scheduler: str) -> str | None:
    """Why nothing can answer at the address `scheduler` (no port, a host
    that does not resolve, a port where nothing listens), found by a plain
    socket at once rather than by Dask's CONNECT_WAIT of retries; None if
    something listens there (or a protocol other than tcp/tls)."""
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port

    protocol, location = parse_address(scheduler)  # ValueError: unknown scheme
    if protocol not in ("tcp", "tls"):
        return None
    host, port = parse_host_port(location)  # ValueError: no port
    if not 0 < port < 65536:
        return f"not an address: port {port} is not one of 1 to 65535"
    try:
        socket.create_connection((host, port), timeout=CONNECT_WAIT).close()
    except socket.gaierror:
        return f"cannot connect: no host {host!r} is known"
    except ConnectionRefusedError:
        return f"cannot connect: nothing listens at port {port} of {host}"
    except TimeoutError:
        return f"cannot connect: {host} does not answer within {CONNECT_WAIT:g} s"
    except OSError as e:
        return f"cannot connect ({_one_line(e)})"
    return None


def _handshake(scheduler: str) -> None:
    """Dask's comm handshake with `scheduler`, given CONNECT_WAIT: Dask's own
    connect waits for the handshake's reply without a limit, so a port that
    accepts but never speaks Dask (a web server, a stuck process) would hang
    the client for ever. In a thread of its own, as the caller may be
    running an event loop (a notebook)."""
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    from distributed.comm import connect
    from distributed.security import Security

    async def probe() -> None:
        args = Security().get_connection_args("client")  # Dask's tls config
        comm = await connect(scheduler, timeout=CONNECT_WAIT, **args)
        await comm.close()

    async def limited() -> None:
        try:
            await asyncio.wait_for(probe(), CONNECT_WAIT)
        except TimeoutError:
            raise OSError(f"Timed out: no handshake in {CONNECT_WAIT:g} s") from None

    with ThreadPoolExecutor(1) as thread:
        thread.submit(asyncio.run, limited()).result()


def _connect(scheduler: str):
    """A client of the scheduler at `scheduler`; ClusterError saying why
    not, in the user's words."""
    from distributed import Client
    from distributed.comm.core import CommClosedError

    tls = scheduler.startswith("tls://")
    certificates = (
        "Dask's distributed.comm.tls.ca-file, .client.cert and .client.key "
        "(or DASK_DISTRIBUTED__COMM__TLS__*)"
    )
    try:
        why = _unreachable(scheduler)
        if why is None:
            _handshake(scheduler)
            return Client(scheduler, timeout=CONNECT_WAIT)
    except TypeError:  # Dask's words: "TLS expects a `ssl_context` argument"
        why = f"cannot connect without a certificate: set {certificates}"
    except OSError as e:
        why = f"cannot connect ({_one_line(e)})"
        # Something listens (`_unreachable` connected), so a tls:// comm
        # closed on connect is the handshake. Either side may close it
        # first: the scheduler refusing the client's certificate (the client
        # then sees "Connection reset by peer" or an SSL error), or the
        # client the scheduler's ("TLS certificate does not match").
        if tls and ("SSL" in str(e) or isinstance(e, CommClosedError)):
            why = (
                "the TLS handshake failed: the scheduler refuses the client's "
                "certificate, or the client the scheduler's (signed by another "
                f"CA?): set {certificates} to the cluster's"
            )
        elif "Timed out" in str(e):
            why = (
                f"no Dask scheduler answers within {CONNECT_WAIT:g} s "
                "(the dashboard's port? a tcp:// address of a tls:// scheduler?)"
            )
    except ValueError as e:  # no port, an unknown scheme
        why = f"not an address ({_one_line(e)})"
    raise ClusterError(f"--scheduler = {scheduler!r}: {why}")


@contextlib.contextmanager
def dask_client(
    workers: int, scheduler: str | None, methods: Sequence[str] = ()
) -> Iterator:
    """A Dask client of the cluster at `scheduler` (tcp:// or tls://, the
    latter with the certificates of Dask's own configuration:
    distributed.comm.tls.*, in a config file or DASK_DISTRIBUTED__COMM__TLS__*
    variables), the client's own modules of `methods` shipped to its workers
    (`ship_modules`); else of a LocalCluster of `workers` single-threaded
    worker processes. Closed on exit. Raises ClusterError if the scheduler
    cannot be reached or refuses the client.

    The local workers are forked from a fork server that has imported this
    module (Drake, the simulation, the reference path) once: a spawned
    worker starts a fresh interpreter and imports all of it, seconds per
    worker on a shared machine, where a fork takes milliseconds. The fork
    server is single-threaded, so forking it is safe, unlike forking this
    process."""
    import dask
    from distributed import Client, LocalCluster
    from distributed.utils import get_mp_context

    if scheduler:
        client = _connect(scheduler)
        with client:
            ship_modules(client, methods)
            yield client
        return
    with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}):
        get_mp_context().set_forkserver_preload(PRELOAD)
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # a free port: no clash with other clusters
            silence_logs=logging.ERROR,
        )
    with cluster, Client(cluster) as client:
        yield client


def _user_modules(methods: Sequence[str]) -> Iterator[str]:
    """The top-level modules of the MODULE:NAME methods."""
    for method in methods:
        if method not in METHOD_NAMES:
            yield method.partition(":")[0].partition(".")[0]


def ship_modules(client, methods: Sequence[str]) -> None:
    """Ships the client's own module of each MODULE:NAME method to every
    worker of the cluster (a Dask worker plugin, so to those joining later
    too): a .py file, or its top-level package as a zip, written into the
    worker's directory and put on its import path. An installed module
    (under site-packages) and this package are not shipped: the workers
    have their own. Importing is left to the tasks, and to `run_tasks`'
    check, which names a worker where it fails."""
    import importlib
    import shutil
    import tempfile

    from distributed import WorkerPlugin

    class ShipModule(WorkerPlugin):
        def __init__(self, filename: str, data: bytes):
            self.filename, self.data = filename, data

        def setup(self, worker) -> None:
            path = os.path.join(worker.local_directory, self.filename)
            with open(path, "wb") as f:
                f.write(self.data)
            entry = path if path.endswith(".zip") else worker.local_directory
            if entry not in sys.path:
                sys.path.insert(0, entry)
            importlib.invalidate_caches()

    for name in dict.fromkeys(_user_modules(methods)):
        path = getattr(importlib.import_module(name), "__file__", None) or ""
        parts = set(os.path.normpath(path).split(os.sep))
        if (
            not path
            or name == "mfi_drake"
            or parts & {"site-packages", "dist-packages"}
        ):
            continue
        with tempfile.TemporaryDirectory() as tmp:
            if os.path.basename(path) == "__init__.py":
                package = os.path.dirname(path)
                path = shutil.make_archive(
                    os.path.join(tmp, name), "zip", os.path.dirname(package), name
                )
            with open(path, "rb") as f:
                plugin = ShipModule(os.path.basename(path), f.read())
        client.register_plugin(plugin, name=f"mfi-drake-ship-{name}")


def _import_problem(methods: Sequence[str]) -> str | None:
    """Run on a worker: the first MODULE:NAME that does not import there."""
    for method in methods:
        try:
            import_field(method)
        except MethodError as e:
            return str(e)
    return None


def _probe() -> Callable[[], tuple[str, str] | None]:
    """The function that tells which mfi_drake a process has: None without
    one, else its __version__ and the hash of its maths sources
    (`compiled.sources_digest`, the compiled engine's cache stamp: a worker
    must compile the client's). Defined in this function, and with a copy
    of `sources_digest`, so that cloudpickle sends their code rather than
    their names in modules that a process without the package, or with
    another version of it, may not import; it imports no more of the
    package than its __init__."""
    digest = types.FunctionType(sources_digest.__code__, {})

    def installed() -> tuple[str, str] | None:
        import importlib
        import os

        try:
            package = importlib.import_module("mfi_drake")
        except ImportError:
            return None
        maths = os.path.join(os.path.dirname(package.__file__), "maths")
        version = getattr(package, "__version__", "without __version__")
        return version, digest(maths)[:12]

    return installed


def _package_words(installed: tuple[str, str] | None) -> str:
    if installed is None:
        return "no mfi_drake"
    return f"mfi_drake {installed[0]} (maths sources {installed[1]})"


def _same_package(mine, where: str, theirs) -> None:
    if theirs != mine:
        raise ClusterError(
            f"{where} has {_package_words(theirs)}, the client "
            f"{_package_words(mine)}: install the client's on every machine "
            "of the cluster"
        )


def check_cluster(client, methods: Sequence[str] = ()) -> None:
    """Refuses the cluster of `client` before any task, with a ClusterError
    naming the machine: a scheduler or worker without the client's
    mfi_drake (its version and its maths sources, both sides named), no
    worker within WORKER_WAIT, or a MODULE:NAME of `methods` that does not
    import on a worker (the module and the worker named)."""
    probe = _probe()
    mine = probe()
    _same_package(mine, "the scheduler", client.run_on_scheduler(probe))
    _wait_for_workers(client, "none joined")
    # A worker that dies meanwhile returns its error: it flies nothing.
    for worker, theirs in client.run(probe, on_error="return").items():
        if not isinstance(theirs, Exception):
            _same_package(mine, f"worker {worker}", theirs)
    if user := [m for m in methods if m not in METHOD_NAMES]:
        checks = client.run(_import_problem, user, on_error="return")
        for worker, problem in checks.items():
            if isinstance(problem, str):
                raise ClusterError(f"--methods: {problem} on worker {worker}")


def _wait_for_workers(client, why: str) -> None:
    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT)
    except TimeoutError:
        raise ClusterError(
            f"the Dask cluster has no workers: {why} within {WORKER_WAIT:g} s"
        ) from None


@dataclass(frozen=True)
class Task:
    """A function to run on the cluster: `args` may hold other Tasks, each
    replaced by its result (run once per key)."""

    key: str  # Dask's key: names the task, the same on a rerun
    function: Callable
    args: tuple


def run_tasks(
    client,
    tasks: Sequence[tuple[object, Task]],
    on_result: Callable[[object, dict], None],
    methods: Sequence[str] = (),
    progress: Progress | None = None,
) -> list[str]:
    """Runs every (tag, task) on the cluster and calls on_result(tag, result)
    once for each as it finishes; returns a line for each task the cluster
    lost (its worker died `distributed.scheduler.allowed-failures` times,
    or a MODULE:NAME that its worker could not import): a rerun retries it.

    First checks the cluster (`check_cluster`: its mfi_drake, a worker
    within WORKER_WAIT, every MODULE:NAME of `methods` importing on every
    worker). A task whose worker dies is run again on another by the
    scheduler; one that killed more than allowed-failures is lost, its
    line saying so. If every worker has gone, it waits WORKER_WAIT for one
    to join, then raises ClusterError (the results handed to on_result
    stay)."""
    from distributed import as_completed
    from distributed.scheduler import KilledWorker

    check_cluster(client, methods)
    submitted = {}

    def submit(task: Task):
        if task.key not in submitted:
            args = [submit(a) if isinstance(a, Task) else a for a in task.args]
            submitted[task.key] = client.submit(task.function, *args, key=task.key)
        return submitted[task.key]

    futures = {submit(task): tag for tag, task in tasks}
    # The scheduler keeps a dependency while a task needs it; a finished
    # task's result is let go with its future, as soon as it is handed on.
    submitted.clear()
    lost = []
    pending = as_completed(futures)
    idle = time.monotonic()
    while not pending.is_empty():
        batch = pending.next_batch(block=False)
        if not batch:
            if time.monotonic() - idle > 5.0 and not client.nthreads():
                _wait_for_workers(client, "all left, and none joined")
                idle = time.monotonic()
            time.sleep(0.1)
            continue
        idle = time.monotonic()
        for future in batch:
            tag = futures.pop(future)
            try:
                result = future.result()
            except KilledWorker as e:
                lost.append(
                    f"{e.task}: it killed {e.allowed_failures + 1} workers, the last "
                    f"{e.last_worker.address} (Dask's distributed.scheduler."
                    f"allowed-failures = {e.allowed_failures})"
                )
            except Exception as e:  # the cluster lost it otherwise
                lost.append(f"{tag}: {_one_line(e)}")
            else:
                on_result(tag, result)
                continue
            if progress is not None:
                progress.step("(lost)")
    return lost
