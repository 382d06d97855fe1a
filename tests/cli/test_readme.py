"""Every command in the README's tour runs as written (from a copy of the repository root)."""

import dataclasses
import itertools
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path, PurePosixPath

import pytest

from tests.cli.test_cli_help import help_examples
from tests.support.paths import ROOT


def tour_commands():
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```sh\n(.*?)```", text, flags=re.DOTALL)
    commands = []
    for block in blocks[1:]:  # the first block is `make demo` / `make test` themselves
        commands += [c.strip() for c in block.replace("\\\n", " ").splitlines() if c.strip()]
    return commands


def test_the_tour_has_the_promised_steps():
    joined = "\n".join(tour_commands())
    for step in (
        "hybridlog inspect",
        "hybridlog analyze",
        "report.md",
        "hybridlog compare",
        "hybridlog batch",
    ):
        assert step in joined, step


def _run_as_written(tmp_path, commands, where=lambda command: command):
    """Each command in ``bash`` from a folder holding the sample logs, as a reader runs it."""
    shutil.copytree(ROOT / "sample_logs", tmp_path / "sample_logs")
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env['PATH']}"
    env.pop("GITHUB_STEP_SUMMARY", None)  # the recipe appends to it on GitHub only
    for command in commands:
        done = subprocess.run(
            ["bash", "-c", command],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            check=False,
            timeout=300,
        )
        assert done.returncode == 0, f"{where(command)}\n{done.stdout}\n{done.stderr}"


def _written_paths(command: str) -> set[PurePosixPath]:
    """The files and folders one example names as outputs (``--out``, ``--junit``, ``--plot``)."""
    words = shlex.split(command)
    return {
        PurePosixPath(value)
        for option, value in itertools.pairwise(words)
        if option in ("--out", "--junit", "--plot")
    }


def tour_chains() -> list[list[str]]:
    """The tour's commands, in README order, split into chains that share no written path.

    A command joins the chains that wrote a path it names (its first folder or file, also as
    a ``--set`` value: the batch's ``runs/*.csv`` joins the simulations into ``runs/``, the
    ``chiu`` analysis the clustering of its centres file) or that write where it
    writes; the others run apart, each in a folder of its own, so the tour's test spreads
    over the test workers rather than running its 36 commands one after another.
    """
    chains: list[tuple[set[str], list[str]]] = []
    written: set[str] = set()
    for command in tour_commands():
        own = {path.parts[0] for path in _written_paths(command)}
        words = [w.partition("=")[2] or w for w in shlex.split(command)]  # --set key=PATH
        named = {PurePosixPath(word).parts[0] for word in words if word}
        touched = own | (named & written)
        joined = [chain for chain in chains if chain[0] & touched]
        chains = [chain for chain in chains if not chain[0] & touched]
        merged = (
            touched.union(*(roots for roots, _ in joined)),
            sorted(
                [c for _, commands in joined for c in commands] + [command],
                key=tour_commands().index,
            ),
        )
        chains.append(merged)
        written |= own
    return sorted((commands for _, commands in chains), key=lambda c: tour_commands().index(c[0]))


def test_the_tour_chains_hold_every_command_once_and_its_dependencies_together():
    chains = tour_chains()
    assert sorted(c for chain in chains for c in chain) == sorted(tour_commands())
    assert len(chains) > 10  # the tour runs spread out
    together = {c: i for i, chain in enumerate(chains) for c in chain}
    for reader, writer in (
        ("cat tank_report/report.md", "--out tank_report"),
        ("hybridlog analyze long.parquet", "--out long.parquet"),
        ("--out ci_report --fail-under", "--out runs/seed2.csv"),
        ("cat ci_report/summary.md", "--junit ci_report/junit.xml"),
        ("--set centers=dc1_centers.json", "--out dc1_centers.json"),
        ("hybridlog inspect sim/tank_ros2", "--out sim/tank_ros2"),
    ):
        (read,) = [c for c in together if reader in c]
        (write,) = [c for c in together if writer in c]
        assert together[read] == together[write], (reader, writer)


@pytest.mark.parametrize(
    "chain", tour_chains(), ids=lambda chain: shlex.split(chain[0])[1] + str(len(chain))
)
def test_readme_tour_runs_as_written(tmp_path, chain):
    _run_as_written(tmp_path, chain)
    if any("--junit" in command for command in chain):
        # the CI recipe's outputs: JUnit with a case per log per gate, the job summary
        junit = (tmp_path / "ci_report" / "junit.xml").read_text()
        assert '<testsuites name="hybridlog batch" tests="4" failures="0" errors="0"' in junit
        assert (tmp_path / "ci_summary.md").read_text().startswith("# Batch: three_tank_hstf")


def test_the_python_section_runs_as_written(tmp_path):
    """README's "From Python" code runs as written, from a folder holding the sample logs."""
    text = (ROOT / "README.md").read_text()
    (block,) = re.findall(r"```python\n(.*?)```", text, flags=re.DOTALL)
    (tmp_path / "from_python.py").write_text(block)
    _run_as_written(tmp_path, ["python from_python.py > printed.txt"])
    printed = (tmp_path / "printed.txt").read_text()
    assert printed.splitlines()[-1].startswith("sets (--set): expected a list of strings")
    assert (tmp_path / "py_report" / "report.json").is_file()
    assert (tmp_path / "py_compare" / "comparison.md").is_file()


def docs_commands():
    """The ``hybridlog`` lines of docs/*.md's command blocks (a study script's are not run)."""
    commands = []
    for page in sorted((ROOT / "docs").glob("*.md")):
        fence = None  # the info string of the block a line is in
        for line in page.read_text().replace("\\\n", " ").splitlines():
            if line.startswith("```"):
                fence = line[3:].strip() if fence is None else None
                continue
            command = line.partition("  #")[0].strip()
            if fence in ("", "sh") and command.startswith("hybridlog "):
                commands.append((page.name, command))
    return commands


def test_the_docs_pages_commands_run_as_written(tmp_path):
    """docs/bioplex.md's commands ran nowhere: the tour's test reads README.md alone."""
    commands = docs_commands()
    assert {page for page, _ in commands} >= {"bioplex.md"}
    pages = {command: page for page, command in commands}
    _run_as_written(tmp_path, pages, lambda command: f"{pages[command]}: {command}")


def test_the_ci_recipe_runs_the_tested_commands():
    """The CI recipe's YAML runs exactly the commands of a tested ```sh block."""
    text = (ROOT / "README.md").read_text()
    (recipe,) = re.findall(r"```yaml\n(.*?)```", text, flags=re.DOTALL)
    runs = [
        line.strip()
        for line in recipe.splitlines()
        if line.strip().startswith(("hybridlog ", "run: hybridlog", "run: cat"))
    ]
    runs = [line.removeprefix("run: ") for line in runs]
    assert any("--junit" in line for line in runs) and any("summary.md" in line for line in runs)
    commands = tour_commands()
    for line in runs:
        tested = line.replace('"$GITHUB_STEP_SUMMARY"', '"${GITHUB_STEP_SUMMARY:-ci_summary.md}"')
        assert tested in commands, line


def test_the_tour_and_the_help_examples_write_different_paths():
    """A user who ran the tour can then run every ``--help`` example in the same folder.

    Both promise to run as written from the repository root; an example that writes where
    the tour already wrote stops with "already exists" or "not empty; use --force".
    """
    tour = set().union(*(_written_paths(c) for c in tour_commands()))
    examples = set().union(*(_written_paths(line) for _, line in help_examples()))
    clashes = sorted(
        f"{a} / {b}" for a in tour for b in examples if a == b or a in b.parents or b in a.parents
    )
    assert not clashes, clashes


def test_the_estimators_table_names_every_estimator_and_its_options():
    """README's table lists each registered estimator with options that exist, and all of them.

    Its option lists were written by hand: ``imm`` listed ``transition_stay`` alone, and
    ``sliding-mode`` and ``switching-observer`` none, while the registry gives them more.
    ``kmeans`` names its own and "the shared ones" (``chiu``'s paper 001 pipeline options).
    """
    from hybridlog.estimators.observer_options import ObserverOptions
    from hybridlog.estimators.registry import ESTIMATORS

    text = (ROOT / "README.md").read_text()
    rows = dict(re.findall(r"^\| `([a-z-]+)` \| (.*?) \| [^|]* \|$", text, flags=re.MULTILINE))
    assert set(rows) == set(ESTIMATORS)
    shared = {f.name for f in dataclasses.fields(ObserverOptions)}
    for name, entry in ESTIMATORS.items():
        listed = {f.name for f in dataclasses.fields(entry.options_type())}
        _, _, options = rows[name].partition("option")
        named = set(re.findall(r"`([a-z_]+)`", options))
        if "the shared ones" in options:
            named |= shared
        assert named == listed, (name, sorted(named ^ listed))
