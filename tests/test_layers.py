"""The package's layers: every import of a mfi_drake module goes to the same
layer or a lower one, the modules import each other without cycles, and
importing them changes nothing in the process (matplotlib's backend, the
umask, pickle's reducers)."""

import ast
import os
import pathlib
import subprocess
import sys

import pytest

import mfi_drake

PACKAGE = pathlib.Path(mfi_drake.__file__).parent
# Lowest first. `files` (atomic writes) is a leaf everyone may use.
LAYERS = ["maths", "config", "world", "systems", "flight", "adapters", "studies", "app"]
RANK = {name: i for i, name in enumerate(LAYERS)} | {"files": 0}


def module_name(path: pathlib.Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {
    module_name(p): p for p in sorted(PACKAGE.rglob("*.py")) if p.parent.name != "tests"
}


def layer(module: str) -> str:
    return module.split(".")[1] if module.count(".") else ""


def _under_type_checking(node, parents) -> bool:
    return any(
        isinstance(p, ast.If) and "TYPE_CHECKING" in ast.unparse(p.test)
        for p in parents
    )


def imported_modules(path: pathlib.Path, type_only: bool = False) -> set[str]:
    """The mfi_drake modules `path` imports at run time, anywhere in it
    (function-level imports included; `if TYPE_CHECKING:` blocks, which
    never run, excluded); with `type_only`, those it imports in `if
    TYPE_CHECKING:` blocks only."""
    tree = ast.parse(path.read_text())
    found, stack = set(), [(tree, [])]
    while stack:
        node, parents = stack.pop()
        for child in ast.iter_child_nodes(node):
            stack.append((child, [*parents, node]))
        if _under_type_checking(node, parents) != type_only:
            continue
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            assert node.level == 0, f"{path}: relative import"
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        else:
            continue
        found |= {n for n in names if n in MODULES}
    return found


GRAPH = {m: imported_modules(p) for m, p in MODULES.items()}
TYPE_ONLY = {m: imported_modules(p, type_only=True) for m, p in MODULES.items()}
# The one upward direction a type-only import may take: the maths functions
# are annotated with the configuration's parameter classes, which they read
# by attribute only (so the maths runs on any object of that shape).
TYPE_ONLY_UPWARD = {("maths", "config")}


def cycle_in(graph: dict[str, set[str]]) -> list[str] | None:
    """An import cycle of `graph` (module → the modules it imports), as the
    path that closes it, or None."""
    colour, path = {}, []  # depth-first search; grey = on the current path

    def visit(module):
        colour[module] = "grey"
        path.append(module)
        for target in graph.get(module, ()):
            if colour.get(target) == "grey":
                return path[path.index(target) :] + [target]
            if target not in colour and (cycle := visit(target)):
                return cycle
        path.pop()
        colour[module] = "black"
        return None

    for module in sorted(graph):
        if module not in colour and (cycle := visit(module)):
            return cycle
    return None


def test_every_module_is_in_a_layer():
    for module in MODULES:
        assert module == "mfi_drake" or layer(module) in RANK, module


@pytest.mark.parametrize("module", sorted(m for m in MODULES if m != "mfi_drake"))
def test_imports_go_only_downward(module):
    for target in GRAPH[module]:
        if target == "mfi_drake":
            pytest.fail(f"{module} imports the package root")
        assert RANK[layer(target)] <= RANK[layer(module)], (
            f"{module} ({layer(module)}) imports {target} ({layer(target)})"
        )


def test_no_import_cycles():
    cycle = cycle_in(GRAPH)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


@pytest.mark.parametrize("module", sorted(m for m in MODULES if m != "mfi_drake"))
def test_type_only_imports_go_only_downward(module):
    for target in TYPE_ONLY[module]:
        upward = RANK[layer(target)] > RANK[layer(module)]
        assert not upward or (layer(module), layer(target)) in TYPE_ONLY_UPWARD, (
            f"{module} ({layer(module)}) imports {target} ({layer(target)}) "
            "for its annotations"
        )


def test_no_type_only_import_closes_a_cycle():
    both = {m: GRAPH[m] | TYPE_ONLY[m] for m in MODULES}
    cycle = cycle_in(both)
    assert cycle is None, "import cycle through type-only imports: " + " -> ".join(
        cycle
    )


def test_the_checker_sees_a_type_only_cycle(tmp_path):
    # The oracle above can fail: a guarded import that closes a loop is seen.
    guarded = tmp_path / "guarded.py"
    guarded.write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from mfi_drake.config import vehicles\n"
    )
    found = imported_modules(guarded, type_only=True)
    assert found == {"mfi_drake.config", "mfi_drake.config.vehicles"}
    graph = {
        "mfi_drake.maths.x": found,
        "mfi_drake.config.vehicles": {"mfi_drake.maths.x"},
    }
    assert cycle_in(graph) == [
        "mfi_drake.config.vehicles",
        "mfi_drake.maths.x",
        "mfi_drake.config.vehicles",
    ]
    assert cycle_in({"a": {"b"}, "b": set()}) is None


def test_the_checker_sees_an_upward_import(tmp_path):
    # The oracle above can fail: a maths module importing the app is caught.
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from mfi_drake.app import cli\n")
    assert imported_modules(bad) == {"mfi_drake.app", "mfi_drake.app.cli"}
    guarded = tmp_path / "guarded.py"
    guarded.write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from mfi_drake.app import cli\n"
    )
    assert imported_modules(guarded) == set()


def test_no_process_wide_switches_in_the_package():
    # The calls that change the process for everyone who imports us.
    forbidden = ("matplotlib.use(", "matplotlib.pyplot", "import pyplot")
    forbidden += ("os.umask(", "copyreg")
    for module, path in MODULES.items():
        text = path.read_text()
        for call in forbidden:
            assert call not in text, f"{module} uses {call}"


def test_importing_every_module_leaves_the_process_as_it_was():
    code = (
        "import importlib, os, matplotlib\n"
        "matplotlib.use('svg')\n"
        "os.umask(0o027)\n"
        f"for name in {sorted(MODULES)!r}:\n"
        "    importlib.import_module(name)\n"
        "assert matplotlib.get_backend() == 'svg', matplotlib.get_backend()\n"
        "assert os.umask(0o027) == 0o027\n"
        "print('ok')\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=os.environ
    )
    assert result.returncode == 0 and result.stdout == "ok\n", result.stderr[-2000:]
