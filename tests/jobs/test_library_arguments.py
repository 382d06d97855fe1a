"""The jobs called from Python with arguments of the wrong type: one ``OptionError`` each.

The command line always hands them strings, tuples and flags; a notebook may not
(``hybridlog/jobs/arguments.py``).  Each call here ended otherwise: a single string read
letter by letter (``--set: 'A' is not NAME=VALUE``, ``--estimators: 'm' named twice``), the
folder ``/`` searched for logs, ``smooth="no"`` smoothing, an ``AttributeError`` or a
``TypeError``.
"""

from pathlib import Path

import numpy as np
import pytest

from hybridlog.errors import OptionError
from hybridlog.estimators.chiu import ChiuOptions
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.cluster import discover_modes
from hybridlog.jobs.compare import compare
from hybridlog.jobs.simulate import simulate_log
from tests.support.paths import ROOT


class _NoPath:
    """An ``os.PathLike`` whose ``__fspath__`` gives neither ``str`` nor ``bytes``."""

    def __fspath__(self) -> int:
        return 3


LOG = ROOT / "sample_logs" / "three_tank_hstf.csv"
MODEL = "three_tank_hstf"

CALLS = {
    "sets one string": (
        lambda out: analyze(LOG, MODEL, out_dir=out, sets="A=150"),
        "sets (--set): expected a list of strings (not one str), got the str 'A=150'",
    ),
    "gates one string": (
        lambda out: analyze(LOG, MODEL, out_dir=out, fail_under="vaf=90"),
        "fail_under (--fail-under): expected a list of strings",
    ),
    "smooth a string": (
        lambda out: analyze(LOG, MODEL, out_dir=out, estimator="imm", smooth="no"),
        "smooth (--smooth): expected True or False, got the str 'no'",
    ),
    "read a dict": (
        lambda out: analyze(LOG, MODEL, out_dir=out, read={"resample": "linear"}),
        "read: expected a hybridlog.io.ReadOptions or None, got the dict",
    ),
    "estimator a number": (
        lambda out: analyze(LOG, MODEL, out_dir=out, estimator=3),
        "estimator (--estimator): expected a string or None, got the int '3'",
    ),
    "log in bytes": (
        lambda out: analyze(bytes(LOG), MODEL, out_dir=out),
        "log: expected a path (a str or pathlib.Path), got the bytes",
    ),
    "estimators one string": (
        lambda out: compare(LOG, MODEL, "imm,hstf", out_dir=out),
        "estimators (--estimators): expected a list of strings (not one str)",
    ),
    "compare without out": (
        lambda out: compare(LOG, MODEL, ["imm"], out_dir=None),
        "out_dir (--out): expected a path",
    ),
    "batch of one path": (  # its first letter, '/', was a folder of logs to search
        lambda out: run_batch(str(LOG), MODEL, out_dir=out),
        "logs: expected a list of paths (write [path] for one), got the str",
    ),
    "batch of no log": (  # wrote a batch folder whose summary said "0 logs: all analysed"
        lambda out: run_batch([], MODEL, out_dir=out),
        "logs (LOGS): no log given; name at least one log, bag or folder of logs",
    ),
    "batch jobs a string": (
        lambda out: run_batch([LOG], MODEL, out_dir=out, jobs="2"),
        "jobs (--jobs): expected an int, got the str '2'",
    ),
    "simulate settings one string": (
        lambda out: simulate_log(MODEL, out / "run.csv", sets="A=150"),
        "sets (--set): expected a list of strings (not one str)",
    ),
    "batch of bytes": (  # a sequence of ints: "expected a path, got the int 99"
        lambda out: run_batch(b"run.csv", MODEL, out_dir=out),
        "logs: expected a list of paths (write [path] for one), got the bytes",
    ),
    "gates in bytes": (
        lambda out: analyze(LOG, MODEL, out_dir=out, fail_under=b"vaf=90"),
        "fail_under (--fail-under): expected a list of strings, got the bytes",
    ),
    "a path naming no path": (  # os.fspath's TypeError
        lambda out: analyze(_NoPath(), MODEL, out_dir=out),
        "log: expected a path (a str or pathlib.Path), got the "
        "tests.jobs.test_library_arguments._NoPath",
    ),
    "seed a float": (
        lambda out: simulate_log(MODEL, out / "run.csv", seed=3.0),
        "seed (--seed): expected an int, got the float '3.0'",
    ),
    "cluster force a string": (
        lambda out: discover_modes(LOG, MODEL, out=out / "centers.json", force="yes"),
        "force (--force): expected True or False, got the str 'yes'",
    ),
    "cluster options a dict": (  # a TypeError from dataclasses after the checks
        lambda out: discover_modes(LOG, MODEL, out=out / "c.json", chiu={"radius": 0.3}),
        "chiu: expected a hybridlog.estimators.chiu.ChiuOptions or None, got the dict",
    ),
    "kmeans options a dict": (  # an AttributeError ('dict' object has no attribute 'clusters')
        lambda out: discover_modes(
            LOG, MODEL, out=out / "c.json", compare_kmeans=True, kmeans={"clusters": 3}
        ),
        "kmeans: expected a hybridlog.estimators.kmeans.KMeansOptions or None, got the dict",
    ),
    "cluster given one string": (  # read as the letters r, a, d, ...: no option given
        lambda out: discover_modes(
            LOG, MODEL, out=out / "c.json", chiu=ChiuOptions(radius=0.3), given="radius"
        ),
        "given: expected a list of names or None (not one str), got the str 'radius'",
    ),
    "cluster given no option": (  # taken without a word
        lambda out: discover_modes(
            LOG, MODEL, out=out / "c.json", chiu=ChiuOptions(radius=0.3), given=["radiuss"]
        ),
        "given: 'radiuss' is no option; expected some of ",
    ),
    "batch progress not callable": (  # 'int' object is not callable after the first log
        lambda out: run_batch([LOG], MODEL, out_dir=out, progress=3),
        "progress: expected a callable or None, got the int '3'",
    ),
    "smooth a numpy bool": (  # refused as "got the bool 'True'", a bool by its name
        lambda out: analyze(LOG, MODEL, out_dir=out, estimator="imm", smooth=np.True_),
        "smooth (--smooth): expected True or False, got the numpy.bool 'True'",
    ),
}


@pytest.mark.parametrize("case", CALLS)
def test_an_argument_of_the_wrong_type_is_one_option_error(tmp_path: Path, case: str) -> None:
    call, message = CALLS[case]
    out = tmp_path / "out"
    with pytest.raises(OptionError) as raised:
        call(out)
    assert str(raised.value).startswith(message), str(raised.value)
    assert "\n" not in str(raised.value)
    assert not out.exists()


def test_a_numpy_integer_is_the_int_it_holds(tmp_path: Path) -> None:
    # rng.integers(...) gives numpy.int64, which 'expected an int' refused
    simulate_log(MODEL, tmp_path / "a.csv", steps=np.int64(30), seed=np.int64(4))
    simulate_log(MODEL, tmp_path / "b.csv", steps=30, seed=4)
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    with pytest.raises(OptionError, match=r"^jobs \(--jobs\): expected an int, got the numpy.bool"):
        run_batch([LOG], MODEL, out_dir=tmp_path / "out", jobs=np.True_)


def test_each_command_line_option_has_one_keyword_across_the_jobs() -> None:
    # simulate_log took --set as settings= where analyze, compare and run_batch take sets=:
    # a notebook's simulate_log(..., sets=[...]) was a TypeError
    import inspect

    from hybridlog.jobs.arguments import OPTIONS

    keywords: dict[str, set[str]] = {}
    for job in (analyze, compare, run_batch, simulate_log, discover_modes):
        for name in inspect.signature(job).parameters:
            if name in OPTIONS:
                keywords.setdefault(OPTIONS[name], set()).add(name)
    keywords.pop("--out")  # out_dir names a folder (analyze, compare, batch), out a file
    assert {option: names for option, names in keywords.items() if len(names) > 1} == {}
    assert keywords["--set"] == {"sets"}
