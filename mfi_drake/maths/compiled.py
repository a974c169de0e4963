"""The scalar maths compiled with numba, for a fleet flown by one integrator
(`systems.fleet.FleetChain`, docs/fleets.md).

No equation is written twice. Each function of `MODULES` is cloned, its
code unchanged, into a namespace of its module's where the names it calls
resolve to the other clones, and compiled there by numba on its first call.
The Python functions stay what the single-vehicle systems and AutoDiffXd
run. A few helpers are swapped for their float forms:

- so3's scalar functions that dispatch on the type for AutoDiffXd (`sqrt`,
  `cos`, `sin`, `floor`, `arccos`, `atan2`) become math's;
- `so3.entries` is the identity: numba unpacks arrays and tuples alike;
- `triples._zeros` and `triples._zero3` give float zeros;
- `motion._length` is √(x² + y² + z²): numba's hypot takes two arguments
  (the two differ in the last bit);
- `so3._value` (an AutoDiffXd's float) is the identity;
- `escape._norm` is √(x·x), numpy's norm of a vector (numba's norm differs
  in the last bit), and `escape._row_norms` sums each row's squares in
  numpy's order (numba's norm takes no axis).

Matrix products (`@`: eq 16–18's rotations, GF's S ṗ) compile as they are:
numba calls SciPy's BLAS, which sums as numpy's does (the same OpenBLAS
kernels: measured equal to the last bit).

Parameters travel as named tuples of a dataclass's fields (`record`): numba
reads a named tuple's attributes as Python reads the dataclass's.

Compiled once per machine: every clone keeps its machine code on disk
(numba's cache, where numba puts it: NUMBA_CACHE_DIR if set, else the
`__pycache__` beside the module if writable, else the user's cache
directory), and a new process loads it instead of compiling (`_persist`).
Two things make that sound where numba alone is not:

- An obstacle field reaches the chain as an argument (`fields.superposed`
  takes `field`), so the caller's cached signature holds the field's
  dispatcher. Numba finds that dispatcher again in a new process by its
  uuid: each clone's is its module and name (`_UUID`), registered before
  any cached code loads, so the field is in effect a compile-time constant
  (each field compiles its own chain) that a later process can name.
- Numba stamps a cached function with its own file alone, while a clone's
  machine code holds the clones it calls from the other modules: the stamp
  here is the hash of every maths module (`sources_digest`, which a
  cluster also compares between its machines), so an edit to any of them
  compiles everything afresh. The first function of a new stamp removes
  the other stamps' directories there (`_prune`).

Processes that start together (xdist or Dask workers on one machine) would
each compile what none has written yet: `specialised` holds a file lock
per function and types while it compiles, so one compiles and the others
load (`_compile_lock`).
"""

import collections
import contextlib
import dataclasses
import fcntl
import functools
import hashlib
import math
import os
import shutil
import time
import types

import numpy as np

from mfi_drake.maths import (
    baselines,
    escape,
    escape_steering,
    fields,
    fleet,
    layout,
    motion,
    quadcopter,
    so3,
    terminal,
    triples,
)

MODULES = (
    so3,
    triples,
    layout,
    terminal,
    fields,
    baselines,
    motion,
    quadcopter,
    escape,
    escape_steering,
    fleet,
)


def _identity(a):
    return a


def _float_zeros(like):
    return (0.0, 0.0, 0.0)


def _float_zero3(like):
    return np.zeros(3)


def _float_length(x, y, z):
    return math.sqrt(x * x + y * y + z * z)


def _float_norm(x):
    return math.sqrt(np.dot(x, x))  # numpy's norm of a vector


def _float_row_norms(x):
    out = np.empty(len(x))
    for i in range(len(x)):
        total = 0.0  # numpy's sum of a row, in its order
        for j in range(x.shape[1]):
            total += x[i, j] * x[i, j]
        out[i] = math.sqrt(total)
    return out


FLOAT_FORMS = {
    "sqrt": math.sqrt,
    "cos": math.cos,
    "sin": math.sin,
    "floor": math.floor,
    "arccos": math.acos,
    "atan2": math.atan2,
    "entries": _identity,
    "_value": _identity,
    "_zeros": _float_zeros,
    "_zero3": _float_zero3,
    "_length": _float_length,
    "_norm": _float_norm,
    "_row_norms": _float_row_norms,
}


def compiled(module: types.ModuleType) -> types.SimpleNamespace:
    """`module`'s functions compiled (one of `MODULES`), by name: one set of
    clones for every module, so that `compiled(fields).obstacle_field` is
    the function `compiled(fleet)`'s callers compile against. Numba is
    imported here only: nothing else in the package needs it."""
    return types.SimpleNamespace(**_namespaces()[module.__name__])


def _namespaces() -> dict[str, dict]:
    """Every module's namespace of compiled clones, by module name: made
    once in a process, by the first of its threads (a Dask client's; two
    sets of clones would share their uuids)."""
    from numba.core.compiler_lock import global_compiler_lock

    with global_compiler_lock:
        return _made_namespaces()


@functools.cache
def _made_namespaces() -> dict[str, dict]:
    import numba

    namespaces = {m.__name__: dict(vars(m)) for m in MODULES}
    clones = {}  # id of a Python function → its compiled clone
    for m in MODULES:
        for obj in vars(m).values():
            if (
                isinstance(obj, types.FunctionType)
                and obj.__module__ == m.__name__
                and obj.__closure__ is None
                and id(obj) not in clones
            ):
                clone = types.FunctionType(
                    obj.__code__, namespaces[m.__name__], obj.__name__, obj.__defaults__
                )
                clones[id(obj)] = _persist(numba.njit(clone), m.__name__)
    swapped = {
        name: _persist(numba.njit(f), __name__)
        if isinstance(f, types.FunctionType)
        else f
        for name, f in FLOAT_FORMS.items()
    }
    for namespace in namespaces.values():
        for name, obj in list(namespace.items()):
            if name in swapped:
                namespace[name] = swapped[name]
            elif id(obj) in clones:
                namespace[name] = clones[id(obj)]
    return namespaces


_UUID = "mfi_drake.maths.compiled:{}.{}"  # a clone's numba uuid: module, name


def _persist(dispatcher, module: str):
    """`dispatcher` (a fresh numba.njit) with its uuid `_UUID` and numba's
    on-disk cache stamped by `_sources_stamp` (the module docstring)."""
    dispatcher._set_uuid(_UUID.format(module, dispatcher.py_func.__name__))
    dispatcher._cache = _cache_class()(dispatcher.py_func)
    return dispatcher


@functools.cache
def _cache_class() -> type:
    """numba's FunctionCache, its locators (numba's, in numba's order)
    stamping a function with `_sources_stamp` and keeping it in a
    directory of that stamp."""
    from numba.core import caching

    def stamped(locator: type) -> type:
        def get_cache_path(self) -> str:
            # A directory per stamp: an index written by other sources may
            # name what these no longer hold, and numba unpickles it whole
            # before it compares the stamps.
            stamp = f"{_STAMP_PREFIX}{_sources_stamp()[:16]}"
            return os.path.join(locator.get_cache_path(self), stamp)

        def ensure_cache_path(self) -> None:
            path = self.get_cache_path()
            new = not os.path.isdir(path)
            locator.ensure_cache_path(self)  # raises where it cannot write
            if new:  # this stamp's first function here: the others' are stale
                _prune(os.path.dirname(path), os.path.basename(path))

        return type(
            locator.__name__,
            (locator,),
            {
                "get_source_stamp": lambda self: _sources_stamp(),
                "get_cache_path": get_cache_path,
                "ensure_cache_path": ensure_cache_path,
            },
        )

    impl = type(
        "StampedCacheImpl",
        (caching.CompileResultCacheImpl,),
        {
            "_locator_classes": [
                stamped(c) for c in caching.CompileResultCacheImpl._locator_classes
            ]
        },
    )
    return type("StampedFunctionCache", (caching.FunctionCache,), {"_impl_class": impl})


_STAMP_PREFIX = "mfi_drake-"  # a stamp's directory: this and 16 hex digits
# Another stamp's directory is removed once nothing was written in it for
# this long [s]: a process of other sources sharing the cache directory
# (another checkout, with NUMBA_CACHE_DIR or the user's) may be compiling.
PRUNE_AFTER = 600.0


def _prune(parent: str, keep: str) -> None:
    """Removes the directories of other stamps than `keep` from `parent`
    (numba's cache directory of the maths; ~7 MB a stamp) where nothing was
    written for PRUNE_AFTER seconds. Only directories named as stamps are:
    numba's and Python's own files there stay."""
    now = time.time()
    for name in os.listdir(parent):
        path = os.path.join(parent, name)
        digits = name.removeprefix(_STAMP_PREFIX)
        if (
            name == keep
            or not name.startswith(_STAMP_PREFIX)
            or len(digits) != 16
            or digits.strip("0123456789abcdef")
            or os.path.islink(path)
            or not os.path.isdir(path)
        ):
            continue
        try:
            files = [path, *(os.path.join(path, f) for f in os.listdir(path))]
            written = max(map(os.path.getmtime, files))
        except OSError:  # removed meanwhile
            continue
        if now - written > PRUNE_AFTER:
            shutil.rmtree(path, ignore_errors=True)


@functools.cache
def _sources_stamp() -> str:
    """`sources_digest` of this package's maths (MODULES and this one among
    them)."""
    return sources_digest(os.path.dirname(os.path.abspath(__file__)))


def sources_digest(maths: str) -> str:
    """The SHA-256 of the maths sources in the directory `maths` (every .py
    file there, by name and bytes): what the compiled engine compiles. It
    imports nothing of the package, so that a copy of it can run where
    another mfi_drake is installed (`studies.cluster`'s probe of workers);
    a missing directory hashes as an empty one."""
    import hashlib
    import os

    digest = hashlib.sha256()
    for name in sorted(os.listdir(maths)) if os.path.isdir(maths) else ():
        if name.endswith(".py"):
            with open(os.path.join(maths, name), "rb") as f:
                digest.update(name.encode() + b"\0" + f.read())
    return digest.hexdigest()


def compiled_form(function: types.FunctionType):
    """The compiled clone of `function`, a function of a module of MODULES
    (e.g. `fields.obstacle_field`)."""
    return _namespaces()[function.__module__][function.__name__]


def specialised(function, *arguments):
    """Calls `function` (a `compiled` one) with `arguments`, compiling it for
    their types, and returns its compiled entry for exactly those types.
    Calling the entry skips numba's typing of every argument at every call:
    with a named tuple of parameters that was 40 µs of a 50 µs call. The
    caller must pass arguments of the same types (C-contiguous, writable
    arrays of the same dimensions, records of the same fields)."""
    kinds = tuple(function.typeof_pyval(a) for a in arguments)
    if kinds not in function.overloads:
        with _compile_lock(function, kinds):
            function(*arguments)
    return function.overloads[kinds].entry_point


def user_field(field, names: tuple[str, ...], *arguments):
    """A user's field `field(position, velocity, obstacle_points, goal,
    **gains)` compiled into `fleet.user_forces`: (that function's compiled
    entry for exactly the types of `arguments`, its arguments after `user`
    and with the gains a tuple in the order of `names`; the compiled
    binding to pass it as `user`). Raises what numba raises where it cannot
    compile `field` (or ValueError for a gain that is no identifier).

    The field compiles once per machine where it is a function of a file
    (numba's own cache, beside that file, stamped by it); its binding and
    the loop calling it once per process and names of gains (~1.5 s):
    their signatures hold the binding, which no later process could name. The
    maths they call load from this module's cache. Compiled, not called: a
    field that raises at some inputs still compiles, and raises in flight
    as on `systems`."""
    from numba.core.compiler_lock import global_compiler_lock

    # Held throughout: threads of one process (a Dask client's) would each
    # make a binding of the field at once (functools.cache does not lock).
    with global_compiler_lock:
        bound, forces = _user_binding(field, tuple(names))
        kinds = (forces.typeof_pyval(bound),)
        kinds += tuple(map(forces.typeof_pyval, arguments))
        if kinds not in forces.overloads:
            forces.compile(kinds)
        return forces.overloads[kinds].entry_point, bound


def compile_error(error: Exception) -> str:
    """One line of what numba raised where it could not compile a function:
    its first line that says why, and where in the user's source."""
    lines = [line.strip() for line in str(error).splitlines()]
    said = [line for line in lines if line and not line.startswith(_NOISE)]
    where = [line for line in lines if line.startswith('File "')]
    why = " ".join((said[0] if said else type(error).__name__).split())[:200]
    return f"{why} ({where[0].rstrip(':')})" if where else why


_NOISE = ("Failed in ", "During:", "File ", "^", "<source", "def ")


@functools.cache
def _user_binding(field, names: tuple[str, ...]) -> tuple:
    """(`field` compiled with its keyword gains bound by position and its
    F_n made an array, `fleet.user_forces` compiled without the disk
    cache)."""
    import numba

    for name in names:
        if not name.isidentifier():
            raise ValueError(f"field_gains.{name}: not a Python identifier")
    user = field
    if not isinstance(field, numba.core.dispatcher.Dispatcher):
        try:  # numba's own cache beside the user's file: compiled once there
            user = numba.njit(field, cache=True)
        except RuntimeError:  # no file to cache beside (a REPL's, exec's)
            user = numba.njit(field)
    namespace = {"np": np, "user": user}
    gains = "".join(f", {name}=gains[{i}]" for i, name in enumerate(names))
    exec(  # a keyword call numba compiles: the names are the field's
        "def bound(position, velocity, obstacle_points, goal, gains):\n"
        "    force = user(position, velocity, obstacle_points, goal" + gains + ")\n"
        "    return np.asarray(force, dtype=np.float64)\n",
        namespace,
    )
    function = fleet.user_forces
    forces = types.FunctionType(
        function.__code__, _namespaces()[fleet.__name__], function.__name__
    )
    return numba.njit(namespace["bound"]), numba.njit(forces)


@contextlib.contextmanager
def _compile_lock(function, kinds: tuple):
    """Holds an exclusive lock on a file of `function`'s cache directory,
    one for its entry of types `kinds`, while this process compiles (or
    loads) that entry: processes starting together (xdist or Dask workers
    on one machine) then compile each chain once, the others load what the
    first wrote (numba alone would compile it in each; ~27 s a chain).
    Without a writable cache directory, no lock."""
    path = _lock_path(function, kinds)
    with contextlib.ExitStack() as held:
        try:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            lock = held.enter_context(open(path, "a"))
        except OSError:
            lock = None
        if lock is not None:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        yield


def _lock_path(function, kinds: tuple) -> str:
    """`_compile_lock`'s file for `function`'s entry of types `kinds`, named
    as every process names it: a compiled function among the types (a
    chain's field) by its module and name. (Its type's repr holds the
    function's address in this process: two processes took different locks
    and compiled the same chain at once, ~30 s of CPU each.)"""
    spelled = tuple(_spelled(kind) for kind in kinds)
    name = hashlib.sha256(repr((function.py_func.__name__, spelled)).encode())
    return os.path.join(function.stats.cache_path, f"{name.hexdigest()[:16]}.lock")


def _spelled(kind) -> str:
    """A numba type as any process spells it (`_lock_path`)."""
    dispatcher = getattr(kind, "dispatcher", None)
    if dispatcher is None:
        return repr(kind)
    return f"compiled {dispatcher.py_func.__module__}.{dispatcher.py_func.__qualname__}"


def record(parameters) -> tuple:
    """A dataclass instance as a named tuple of its fields and properties
    (a dataclass among them as its own record), for `compiled` functions."""
    names = [f.name for f in dataclasses.fields(parameters)]
    kind = type(parameters)
    names += [n for n in dir(kind) if isinstance(getattr(kind, n), property)]
    values = (getattr(parameters, name) for name in names)
    nested = (record(v) if dataclasses.is_dataclass(v) else v for v in values)
    return _record_type(kind.__name__, tuple(names))(*nested)


@functools.cache
def _record_type(name: str, names: tuple[str, ...]) -> type:
    """The named tuple type of `record`, an attribute of this module by a
    name that spells its fields (`__getattr__`): numba's cached signatures
    hold the type, pickled by that name, and a later process rebuilds the
    same type from it (a type made anew would match no cached signature)."""
    kind = collections.namedtuple(name, names)
    kind.__qualname__ = f"{_RECORD}{name}:{','.join(names)}"
    kind.__module__ = __name__
    return kind


_RECORD = "record:"  # how the names of `_record_type`'s types begin


def __getattr__(attribute: str) -> type:
    """`_record_type`'s type by its name (PEP 562: the module's attributes
    that are not defined in it)."""
    if not attribute.startswith(_RECORD):
        raise AttributeError(f"module {__name__!r} has no attribute {attribute!r}")
    name, names = attribute.removeprefix(_RECORD).split(":")
    return _record_type(name, tuple(names.split(",")))
