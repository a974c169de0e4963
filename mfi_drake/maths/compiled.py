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
- `fields._zeros` and `fields._zero3` give float zeros;
- `motion._length` is √(x² + y² + z²): numba's hypot takes two arguments
  (the two differ in the last bit);
- `fields._paper_attraction`, eq 16–18 by rotation matrices (numba's matrix
  product needs SciPy's BLAS), raises: a fleet whose parameters turn that
  way is refused before it flies (`flight.fleet.unsupported`).

Parameters travel as named tuples of a dataclass's fields (`record`): numba
reads a named tuple's attributes as Python reads the dataclass's.
"""

import collections
import dataclasses
import functools
import math
import types

import numpy as np

from mfi_drake.maths import fields, fleet, layout, motion, quadcopter, so3

MODULES = (so3, layout, fields, motion, quadcopter, fleet)


def _identity(a):
    return a


def _float_zeros(like):
    return (0.0, 0.0, 0.0)


def _float_zero3(like):
    return np.zeros(3)


def _float_length(x, y, z):
    return math.sqrt(x * x + y * y + z * z)


def _not_compiled(v, l_a, l_g, K_omega):
    if K_omega == K_omega:  # always; numba types the caller by the return below
        raise ValueError("eq 16-18's rotation matrices are not compiled")
    return (K_omega, K_omega, K_omega)


FLOAT_FORMS = {
    "sqrt": math.sqrt,
    "cos": math.cos,
    "sin": math.sin,
    "floor": math.floor,
    "arccos": math.acos,
    "atan2": math.atan2,
    "entries": _identity,
    "_zeros": _float_zeros,
    "_zero3": _float_zero3,
    "_length": _float_length,
    "_paper_attraction": _not_compiled,
}


def compiled(module: types.ModuleType) -> types.SimpleNamespace:
    """`module`'s functions compiled (one of `MODULES`), by name: one set of
    clones for every module, so that `compiled(fields).obstacle_field` is
    the function `compiled(fleet)`'s callers compile against. Numba is
    imported here only: nothing else in the package needs it."""
    return types.SimpleNamespace(**_namespaces()[module.__name__])


@functools.cache
def _namespaces() -> dict[str, dict]:
    """Every module's namespace of compiled clones, by module name."""
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
                clones[id(obj)] = numba.njit(clone, cache=_cacheable(obj))
    swapped = {
        name: numba.njit(f, cache=True) if isinstance(f, types.FunctionType) else f
        for name, f in FLOAT_FORMS.items()
    }
    for namespace in namespaces.values():
        for name, obj in list(namespace.items()):
            if name in swapped:
                namespace[name] = swapped[name]
            elif id(obj) in clones:
                namespace[name] = clones[id(obj)]
    return namespaces


def specialised(function, *arguments):
    """Calls `function` (a `compiled` one) with `arguments`, compiling it for
    their types, and returns its compiled entry for exactly those types.
    Calling the entry skips numba's typing of every argument at every call:
    with a named tuple of parameters that was 40 µs of a 50 µs call. The
    caller must pass arguments of the same types (C-contiguous, writable
    arrays of the same dimensions, records of the same fields)."""
    function(*arguments)
    kinds = tuple(function.typeof_pyval(a) for a in arguments)
    return function.overloads[kinds].entry_point


def _cacheable(function: types.FunctionType) -> bool:
    """Whether numba may keep `function`'s machine code on disk for the next
    process: not where it is given another compiled function (an obstacle
    `field`, by this package's convention), whose type is that process's
    dispatcher object (a later process found the cached entry's dispatcher
    vanished: ReferenceError)."""
    code = function.__code__
    return "field" not in code.co_varnames[: code.co_argcount]


def record(parameters) -> tuple:
    """A dataclass instance as a named tuple of its fields and properties,
    for `compiled` functions."""
    names = [f.name for f in dataclasses.fields(parameters)]
    kind = type(parameters)
    names += [n for n in dir(kind) if isinstance(getattr(kind, n), property)]
    values = (getattr(parameters, name) for name in names)
    return _record_type(kind.__name__, tuple(names))(*values)


@functools.cache
def _record_type(name: str, names: tuple[str, ...]) -> type:
    return collections.namedtuple(name, names)
