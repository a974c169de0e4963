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
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

from mfi_drake.flight.methods import METHODS, MethodError, import_field

# What the local workers' fork server imports once (`dask_client`): the
# sweep's module, whose tasks every study runs (Drake, the simulation, the
# reference path), named here without importing it.
PRELOAD = ["distributed", "mfi_drake.studies.sweep"]


# --- the run ----------------------------------------------------------------------
class Progress:
    """A text progress bar on stderr (a line per 10 % when not a terminal)."""

    def __init__(self, total: int, stream=sys.stderr):
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


def _one_line(e: BaseException) -> str:
    return f"{type(e).__name__}: {' '.join(str(e).split())}"[:300]


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
        try:
            client = Client(scheduler, timeout=10)
        except (OSError, TypeError, ValueError) as e:
            why = f"({_one_line(e)})"
            if isinstance(e, TypeError) and scheduler.startswith("tls://"):
                why = (  # Dask's words: "TLS expects a `ssl_context` argument"
                    "without a certificate: set Dask's distributed.comm.tls.ca-file, "
                    ".client.cert and .client.key (or DASK_DISTRIBUTED__COMM__TLS__*)"
                )
            raise ClusterError(
                f"--scheduler = {scheduler!r}: cannot connect {why}"
            ) from None
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
        if method not in METHODS:
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

    First waits up to WORKER_WAIT for a worker and checks that every
    MODULE:NAME of `methods` imports on every worker (ClusterError naming
    the module and the worker if not). A task whose worker dies is run
    again on another by the scheduler. If every worker has gone, it waits
    WORKER_WAIT for one to join, then raises ClusterError (the results
    handed to on_result stay)."""
    from distributed import as_completed

    _wait_for_workers(client, "none joined")
    if user := [m for m in methods if m not in METHODS]:
        # A worker that dies meanwhile returns its error: it flies nothing.
        checks = client.run(_import_problem, user, on_error="return")
        for worker, problem in checks.items():
            if isinstance(problem, str):
                raise ClusterError(f"--methods: {problem} on worker {worker}")
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
            except Exception as e:  # the cluster lost it (a killed worker, ...)
                lost.append(f"{tag}: {_one_line(e)}")
                if progress is not None:
                    progress.step("(lost)")
                continue
            on_result(tag, result)
    return lost
