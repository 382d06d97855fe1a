"""A light start (issue 8): help, the version and ``models`` import no heavy library.

Batch users start thousands of processes; each must not pay for numpy, polars, numba, sympy,
scipy or matplotlib just to print help.  Each command imports what it needs when it runs.
The check runs the CLI in a fresh interpreter and reads ``sys.modules`` afterwards: what
was imported, not how long it took.
"""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
from importlib import metadata

import pytest

import hybridlog
from hybridlog.cli import cli

HEAVY = (
    "numpy",
    "numba",
    "llvmlite",
    "sympy",
    "scipy",
    "matplotlib",
    "polars",
    "cvxpy",
    "rosbags",
    "mcap",
    "mcap_ros1",
    "mcap_ros2",
)

RUNNER = """
import json, sys
from hybridlog.cli import main

heavy = set(json.loads(sys.argv[1]))
found = {}
for args in json.loads(sys.argv[2]):
    try:
        main(args)
    except SystemExit as exit_:
        assert exit_.code in (0, None), (args, exit_.code)
    found[" ".join(args)] = sorted({name.split(".")[0] for name in sys.modules} & heavy)
print(json.dumps(found))
"""


def heavy_imports(*commands: list[str]) -> dict[str, list[str]]:
    """Heavy top-level packages in ``sys.modules`` after each command, run in one process.

    The sets only grow, so the first command that lists a package is the one that imported it.
    """
    done = subprocess.run(
        [sys.executable, "-c", RUNNER, json.dumps(HEAVY), json.dumps(commands)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    found: dict[str, list[str]] = json.loads(done.stdout.splitlines()[-1])
    return found


LIGHT_COMMANDS = sorted(set(cli.commands) - {"cluster"})


def test_help_version_and_models_import_no_heavy_library():
    commands = [
        ["--help"],
        ["--version"],
        ["models"],
        ["models", "three_tank_hstf"],
        *([name, "--help"] for name in LIGHT_COMMANDS),
    ]
    found = heavy_imports(*commands)
    assert list(found) == [" ".join(c) for c in commands]
    assert not any(found.values()), found


def test_cluster_help_imports_no_heavy_library():
    found = heavy_imports(["cluster", "--help"])
    assert not found["cluster --help"], found


@pytest.mark.parametrize("package", ["hybridlog.io", "hybridlog.report", "hybridlog.cluster"])
def test_lazy_package_exports_resolve(package):
    module = importlib.import_module(package)
    assert set(module.__all__) <= set(dir(module))
    for name in module.__all__:
        value = getattr(module, name)
        defined_in = getattr(value, "__module__", None)
        if defined_in is not None and defined_in.startswith("hybridlog."):
            assert getattr(importlib.import_module(defined_in), name) is value, name
    with pytest.raises(AttributeError, match="no_such_name"):
        module.no_such_name  # noqa: B018


def test_the_version_is_written_once():
    # hybridlog/__init__.py holds it (a metadata lookup costs 0.06 s per start);
    # pyproject.toml reads it from there, so the installed metadata agrees.
    assert metadata.version("hybridlog") == hybridlog.__version__


OPTIONS_RUNNER = """
import json, sys
from hybridlog.estimators.registry import ESTIMATORS

for estimator in ESTIMATORS.values():
    estimator.describe_options()
    estimator.parse_options({})
print(json.dumps(sorted({name.split(".")[0] for name in sys.modules})))
"""


def test_estimator_options_are_read_without_the_compiler():
    # batch checks every option before its workers start; the parent must not pay for numba
    done = subprocess.run(
        [sys.executable, "-c", OPTIONS_RUNNER], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    loaded = set(json.loads(done.stdout.splitlines()[-1]))
    assert not loaded & {"numba", "llvmlite", "scipy", "cvxpy", "sympy", "matplotlib"}, loaded


def test_checking_a_model_file_imports_what_its_kind_needs(tmp_path):
    # `models FILE` of a model without [components] imported scipy.sparse (0.1-0.2 s, the
    # loader's components graph checks); sympy it needs, to parse the expressions.
    from hybridlog.model.builtins import builtin_text

    path = tmp_path / "tank.toml"
    path.write_text(builtin_text("three_tank_hstf"), encoding="utf-8")
    found = heavy_imports(["models", str(path)])
    assert found[f"models {path}"] == ["numpy", "sympy"], found
