"""The layers of the house (issue 8): imports point down, packages form no cycle, and the
algorithm packages read and write no file.

Every module of ``hybridlog/`` is parsed with :mod:`ast` (nothing is imported); every
``import``/``from ... import`` counts, at module level, inside functions and under
``TYPE_CHECKING`` alike, and so does a string naming a hybridlog module (the estimator
registry imports its modules by name).  Each module belongs to a *unit*: a subpackage
(``hybridlog/io/...`` is ``io``) or a top-level module (``hybridlog/jit.py`` is ``jit``;
``simulate``, ``simulate_components`` and the ``simulation_*`` modules form the unit
``simulation``).  Units sit in layers, lowest first; a unit may import its own modules and
units of lower layers only, so units of one layer are peers that never import each other:

==  ==============================================================================
0   ``hybridlog`` (its version) | ``errors`` | ``lazy`` | ``background`` | ``allocators``
    | ``prefault`` | ``polars_import`` (polars, with ``SIGINT`` left to Python) | ``numbers``
    (numbers typed on the command line, read strictly) | ``times`` (times written for people)
    | ``cgroups`` (the control groups' CPU and memory limits) | ``limits`` (the process's
    ``ulimit`` limits and umask)
1   ``signals`` | ``jit`` | ``outputs`` (the output-path rules every writer follows) | ``memory``
    | ``environment`` (the libraries' settings from the environment, checked up front)
2   ``io`` | ``model``
3   ``cluster``
4   ``estimators`` | ``simulation``
5   ``report``
6   ``jobs``
7   ``cli`` (``cli``, ``cli_types``, ``cli_options``, ``cli_lines``, ``cli_progress``,
    ``cli_process``, ``fitted_lines``, ``__main__``, ``launch``)
==  ==============================================================================

A module that belongs to no unit of this table fails the test: a new top-level module or
package must be given its place here.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import textwrap
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import csr_array
from scipy.sparse.csgraph import connected_components

PACKAGE = Path(__file__).resolve().parent.parent / "hybridlog"

LAYERS: tuple[tuple[str, ...], ...] = (
    (
        "hybridlog",
        "errors",
        "lazy",
        "background",
        "allocators",
        "prefault",
        "polars_import",
        "numbers",
        "times",
        "cgroups",
        "limits",
    ),
    ("signals", "jit", "outputs", "memory", "environment"),
    ("io", "model"),
    ("cluster",),
    ("estimators", "simulation"),
    ("report",),
    ("jobs",),
    ("cli",),
)
"""Units by layer, lowest first."""

UNIT_OF_MODULE = {
    "hybridlog": "hybridlog",
    "hybridlog.simulate": "simulation",
    "hybridlog.simulation_kernels": "simulation",
    "hybridlog.simulate_components": "simulation",
    "hybridlog.simulation_inputs": "simulation",
    "hybridlog.simulation_range": "simulation",
    "hybridlog.simulation_domains": "simulation",
    "hybridlog.simulation_limits": "simulation",
    "hybridlog.simulation_schedule": "simulation",
    "hybridlog.__main__": "cli",
    "hybridlog.launch": "cli",
    "hybridlog.fitted_lines": "cli",
    "hybridlog.cli_types": "cli",
    "hybridlog.cli_options": "cli",
    "hybridlog.cli_lines": "cli",
    "hybridlog.cli_progress": "cli",
    "hybridlog.cli_process": "cli",
}
"""Top-level modules whose unit is not their own name."""

PURE = ("cluster", "estimators")
"""Units that hold algorithms over arrays: they read and write no file."""

# --- the import graph --------------------------------------------------------------------------


@dataclass(frozen=True)
class Edge:
    """``importer`` imports ``imported`` (both module names) at ``line``."""

    importer: str
    imported: str
    line: int


def modules(package: Path) -> dict[str, Path]:
    """Every module of the package under ``package`` by dotted name."""
    found: dict[str, Path] = {}
    for path in sorted(package.rglob("*.py")):
        parts = list(path.relative_to(package.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found[".".join(parts)] = path
    return found


def _existing(name: str, known: dict[str, Path]) -> str | None:
    """The longest prefix of ``name`` that is a known module (``a.b.func`` → ``a.b``)."""
    while name and name not in known:
        name = name.rpartition(".")[0]
    return name or None


def imports(package: Path) -> list[Edge]:
    """Every import between modules of the package (including the package's ``__init__``)."""
    known = modules(package)
    root = package.name
    edges: list[Edge] = []
    for name, path in known.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        here = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
        for node in ast.walk(tree):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = here[: len(here) - node.level + 1]
                    module = ".".join([*base, *([node.module] if node.module else [])])
                else:
                    module = node.module or ""
                # ``from a import b`` imports ``a`` and, when it is one, the submodule ``a.b``
                targets = [module, *(f"{module}.{alias.name}" for alias in node.names)]
            elif isinstance(node, ast.Constant) and node.value in known:
                targets = [str(node.value)]  # a module imported by name (importlib)
            for target in targets:
                if target != root and not target.startswith(f"{root}."):
                    continue
                module = _existing(target, known)
                edge = Edge(name, module or "", getattr(node, "lineno", 0))
                if module is not None and module != name and edge not in edges:
                    edges.append(edge)
    return edges


def unit(module: str) -> str:
    """The unit a module belongs to (see the module docstring)."""
    if module in UNIT_OF_MODULE:
        return UNIT_OF_MODULE[module]
    return module.split(".")[1]


def layer(name: str) -> int:
    """The layer of a unit; a unit missing from :data:`LAYERS` fails with its name."""
    for level, units in enumerate(LAYERS):
        if name in units:
            return level
    raise AssertionError(f"unit {name!r} has no layer: give it its place in LAYERS")


def unit_graph(edges: list[Edge]) -> dict[tuple[str, str], list[Edge]]:
    """Edges between different units, with the module imports behind each."""
    graph: dict[tuple[str, str], list[Edge]] = {}
    for edge in edges:
        pair = (unit(edge.importer), unit(edge.imported))
        if pair[0] != pair[1]:
            graph.setdefault(pair, []).append(edge)
    return graph


def cycles(graph: dict[tuple[str, str], list[Edge]]) -> list[list[str]]:
    """Groups of units that import each other in a circle (strongly connected components)."""
    names = sorted({u for pair in graph for u in pair})
    index = {u: i for i, u in enumerate(names)}
    rows = [index[a] for a, _ in graph]
    columns = [index[b] for _, b in graph]
    adjacency = csr_array((np.ones(len(rows)), (rows, columns)), shape=(len(names),) * 2)
    count, labels = connected_components(adjacency, directed=True, connection="strong")
    groups = [[names[i] for i in np.flatnonzero(labels == c)] for c in range(count)]
    return [group for group in groups if len(group) > 1]


def upward(graph: dict[tuple[str, str], list[Edge]]) -> list[str]:
    """Imports of a unit of the same or a higher layer, one line each."""
    return [
        f"{e.importer} (line {e.line}) imports {e.imported}: {a} (layer {layer(a)}) -> "
        f"{b} (layer {layer(b)})"
        for (a, b), found in sorted(graph.items())
        if layer(b) >= layer(a)
        for e in found
    ]


# --- file I/O in the pure units ----------------------------------------------------------------

_FILE_METHODS = {
    "read_text",
    "read_bytes",
    "write_text",
    "write_bytes",
    "open",
    "touch",
    "mkdir",
    "rmdir",
    "unlink",
    "iterdir",
    "glob",
    "rglob",
    "savefig",
    "print_figure",
    "tofile",
    "write_csv",
    "write_parquet",
    "to_csv",
}
"""Method names that read or write files whatever they are called on."""

_FILE_FUNCTIONS = {
    "os": {
        "open",
        "fdopen",
        "remove",
        "unlink",
        "rename",
        "replace",
        "mkdir",
        "makedirs",
        "rmdir",
        "removedirs",
        "listdir",
        "scandir",
        "walk",
        "link",
        "symlink",
        "truncate",
    },
    "json": {"dump", "load"},
    "pickle": {"dump", "load"},
    "tomllib": {"load"},
    "np": {"save", "savez", "savez_compressed", "load", "loadtxt", "savetxt", "genfromtxt"},
    "numpy": {"save", "savez", "savez_compressed", "load", "loadtxt", "savetxt", "genfromtxt"},
    "pl": {"read_csv", "read_parquet", "scan_csv", "scan_parquet"},
    "polars": {"read_csv", "read_parquet", "scan_csv", "scan_parquet"},
}
"""Module-level functions that read or write files, by the module's usual name."""

_FILE_MODULES = {"shutil", "tempfile", "pathlib", "io", "glob", "pickle", "sqlite3"}
"""Standard modules that are about files: importing them at all is a finding."""


def file_io(path: Path) -> Iterator[str]:
    """File reads and writes in one module (calls and imports), one line each."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import | ast.ImportFrom):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else ([node.module or ""] if not node.level else [])
            )
            for name in names:
                if name.split(".")[0] in _FILE_MODULES:
                    yield f"line {node.lineno}: imports {name}"
        if not isinstance(node, ast.Call):
            continue
        function = node.func
        if isinstance(function, ast.Name) and function.id == "open":
            yield f"line {node.lineno}: open()"
        elif isinstance(function, ast.Attribute):
            owner = function.value.id if isinstance(function.value, ast.Name) else None
            if function.attr in _FILE_METHODS:
                yield f"line {node.lineno}: .{function.attr}()"
            elif owner is not None and function.attr in _FILE_FUNCTIONS.get(owner, ()):
                yield f"line {node.lineno}: {owner}.{function.attr}()"


def file_io_in(package: Path, units: tuple[str, ...]) -> list[str]:
    """Every file read or write in the modules of ``units``."""
    return [
        f"{name}: {finding}"
        for name, path in modules(package).items()
        if unit(name) in units
        for finding in file_io(path)
    ]


# --- the tests ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def graph() -> dict[tuple[str, str], list[Edge]]:
    return unit_graph(imports(PACKAGE))


def test_every_module_has_a_layer() -> None:
    for name in modules(PACKAGE):
        layer(unit(name))


def test_no_import_cycle_between_packages(graph: dict[tuple[str, str], list[Edge]]) -> None:
    found = cycles(graph)
    where = [
        f"{a} -> {b}: {graph[a, b][0].importer} imports {graph[a, b][0].imported}"
        for group in found
        for a in group
        for b in group
        if (a, b) in graph
    ]
    assert found == [], "\n".join(where)


def test_no_module_imports_upward(graph: dict[tuple[str, str], list[Edge]]) -> None:
    assert upward(graph) == []


def test_algorithm_packages_read_and_write_no_file() -> None:
    assert file_io_in(PACKAGE, PURE) == []


def test_the_jobs_are_what_the_cli_calls(graph: dict[tuple[str, str], list[Edge]]) -> None:
    # The algorithms of paper 001 and the estimators are reached through the jobs; nothing
    # below the jobs imports them (the graph holds real edges, so this checks the reader too).
    assert ("jobs", "cluster") in graph and ("jobs", "estimators") in graph
    assert ("estimators", "cluster") in graph
    assert not any(b == "jobs" for a, b in graph if a != "cli")


def test_files_an_estimator_option_names_are_read_by_the_jobs() -> None:
    # An option naming an input file (FILE_OPTIONS) is read by the job and handed to the
    # run function as the keyword of the same name; the estimator itself reads no file.
    from hybridlog.estimators import ESTIMATORS
    from hybridlog.jobs.estimation import FILE_OPTIONS

    taking = set()
    for name, entry in ESTIMATORS.items():
        fields = {f.name for f in dataclasses.fields(entry.options_type)}
        parameters = inspect.signature(entry.run_function).parameters
        for option in fields & set(FILE_OPTIONS):
            assert parameters[option].kind is inspect.Parameter.KEYWORD_ONLY, (name, option)
            taking.add(name)
    assert taking >= {"chiu", "kmeans"}


def _tree(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = root / "hybridlog" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return root / "hybridlog"


def test_the_checks_find_cycles_upward_imports_and_file_io(tmp_path: Path) -> None:
    package = _tree(
        tmp_path,
        {
            "__init__.py": "",
            "errors.py": "",
            "cluster/__init__.py": "",
            "cluster/fit.py": """
                def fit():
                    from ..estimators import chiu  # relative, inside a function
                    return open("centers.json").read()
            """,
            "estimators/__init__.py": "",
            "estimators/chiu.py": """
                from typing import TYPE_CHECKING
                import json
                from hybridlog.cluster.fit import fit
                if TYPE_CHECKING:
                    from hybridlog.report import Report
                JOB = "hybridlog.jobs.run"
                def save(p, x):
                    p.write_text(json.dumps(x))
                    json.dump(x, p)
            """,
            "report/__init__.py": "import shutil\n",
            "jobs/__init__.py": "",
            "jobs/run.py": "from hybridlog import errors\n",
        },
    )
    graph = unit_graph(imports(package))
    assert cycles(graph) == [["cluster", "estimators"]]
    found = upward(graph)
    assert sorted(line.split(":")[0] for line in found) == [
        "hybridlog.cluster.fit (line 3) imports hybridlog.estimators",
        "hybridlog.cluster.fit (line 3) imports hybridlog.estimators.chiu",
        "hybridlog.estimators.chiu (line 6) imports hybridlog.report",
        "hybridlog.estimators.chiu (line 7) imports hybridlog.jobs.run",  # by name
    ]
    assert found[0].endswith(": cluster (layer 3) -> estimators (layer 4)")
    assert file_io_in(package, PURE) == [
        "hybridlog.cluster.fit: line 4: open()",
        "hybridlog.estimators.chiu: line 9: .write_text()",
        "hybridlog.estimators.chiu: line 10: json.dump()",
    ]
    assert file_io_in(package, ("report",)) == ["hybridlog.report: line 1: imports shutil"]
