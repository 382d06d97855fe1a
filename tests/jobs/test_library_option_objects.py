"""The options objects a notebook builds, their fields of the wrong type: one ``OptionError``.

``ReadOptions`` and the clustering options are dataclasses, which take any value: a job
checked that ``read=`` is a ``ReadOptions`` (``tests/jobs/test_library_arguments.py``) but
not what it holds.  ``ReadOptions(max_gap="0.5")`` ended in a bare ``TypeError``,
``maps="y1=level"`` and ``msg_dirs="msgs"`` were read letter by letter (``--map 'y'``),
``sort="no"`` sorted; ``ChiuOptions(radius="0.3")`` clustered and wrote ``"radius": "0.3"``
into centers.json, and ``radius=1e-9``, outside the range ``--radius`` is held to, ran.
"""

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from hybridlog.errors import OptionError
from hybridlog.estimators.chiu import ChiuOptions
from hybridlog.estimators.kmeans import KMeansOptions
from hybridlog.io import ReadOptions
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.cluster import discover_modes
from tests.support.paths import ROOT

LOG = ROOT / "sample_logs" / "three_tank_hstf.csv"
MODEL = "three_tank_hstf"

READ: dict[str, tuple[Callable[[], ReadOptions], str]] = {
    "max_gap text": (
        lambda: ReadOptions(max_gap="0.5"),  # type: ignore[arg-type]
        "ReadOptions max_gap (--max-gap): expected a number of seconds or None, got the str",
    ),
    "maps one string": (
        lambda: ReadOptions(maps="y1=y1"),  # type: ignore[arg-type]
        "ReadOptions maps (--map): expected a list of strings (write [x] for one), got the str",
    ),
    "msg_dirs one string": (
        lambda: ReadOptions(msg_dirs="/tmp"),  # type: ignore[arg-type]
        "ReadOptions msg_dirs (--msg-dir): expected a list of paths (write [x] for one)",
    ),
    "a map not text": (
        lambda: ReadOptions(maps=(3,)),  # type: ignore[arg-type]
        "ReadOptions maps (--map): expected a list of strings, got the int '3'",
    ),
    "sort text": (
        lambda: ReadOptions(sort="no"),  # type: ignore[arg-type]
        "ReadOptions sort (--sort): expected True or False, got the str 'no'",
    ),
    "recover a number": (
        lambda: ReadOptions(recover=1),  # type: ignore[arg-type]
        "ReadOptions recover (--recover): expected True or False, got the int '1'",
    ),
    "max_gap a bool": (
        lambda: ReadOptions(max_gap=True),
        "ReadOptions max_gap (--max-gap): expected a number of seconds or None, got the bool",
    ),
    "max_gap beyond floats": (  # math.isfinite(10**400) is an OverflowError
        lambda: ReadOptions(max_gap=10**400),
        "--max-gap: must be between 0 and 1e+09 seconds, got inf",
    ),
}


@pytest.mark.parametrize("case", READ)
def test_read_options_of_the_wrong_type_are_one_option_error(case: str) -> None:
    build, message = READ[case]
    with pytest.raises(OptionError) as raised:
        build()
    assert str(raised.value).startswith(message), str(raised.value)
    assert "\n" not in str(raised.value)


def test_read_options_take_paths_lists_and_numpy_numbers() -> None:
    read = ReadOptions(maps=["y1=y1"], msg_dirs=[Path("/tmp")], max_gap=np.float32(0.5))
    assert read.maps == ("y1=y1",) and read.msg_dirs == ("/tmp",)
    assert read.max_gap == 0.5 and type(read.max_gap) is float
    hash(read)  # frozen, of tuples: usable as a key


CLUSTER: dict[str, tuple[Callable[[Path], object], str]] = {
    "radius text": (
        lambda out: discover_modes(LOG, MODEL, out=out, chiu=ChiuOptions(radius="0.3")),  # type: ignore[arg-type]
        "chiu.radius: expected a finite number, got the string '0.3'",
    ),
    "radius out of range": (
        lambda out: discover_modes(LOG, MODEL, out=out, chiu=ChiuOptions(radius=1e-9)),
        "chiu.radius: 1e-09 is outside [0.001, 100]",
    ),
    "method unknown": (
        lambda out: discover_modes(LOG, MODEL, out=out, chiu=ChiuOptions(method="fast")),  # type: ignore[arg-type]
        "chiu.method: 'fast' is not one of auto, exact, approximate",
    ),
    "self_potential text": (
        lambda out: discover_modes(LOG, MODEL, out=out, chiu=ChiuOptions(self_potential="no")),  # type: ignore[arg-type]
        "chiu.self_potential: expected true or false, got the string 'no'",
    ),
    "kmeans clusters 0": (
        lambda out: discover_modes(
            LOG, MODEL, out=out, compare_kmeans=True, kmeans=KMeansOptions(clusters=0)
        ),
        "kmeans.clusters: 0 is outside [1, 1000]",
    ),
}


@pytest.mark.parametrize("case", CLUSTER)
def test_clustering_options_of_the_wrong_value_are_one_option_error(
    tmp_path: Path, case: str
) -> None:
    call, message = CLUSTER[case]
    out = tmp_path / "centers.json"
    with pytest.raises(OptionError) as raised:
        call(out)
    assert str(raised.value).startswith(message), str(raised.value)
    assert "\n" not in str(raised.value)
    assert list(tmp_path.iterdir()) == []


def test_clustering_options_are_recorded_as_their_type(tmp_path: Path) -> None:
    # radius=1 (an int) and a NumPy seed: the file records the numbers the options hold
    out = tmp_path / "centers.json"
    discover_modes(
        LOG,
        MODEL,
        out=out,
        chiu=ChiuOptions(radius=1),
        compare_kmeans=True,
        kmeans=KMeansOptions(seed=np.int64(3)),  # type: ignore[arg-type]
    )
    content = json.loads(out.read_text(encoding="utf-8"))
    assert content["chiu"]["parameters"]["radius"] == 1.0
    assert isinstance(content["chiu"]["parameters"]["radius"], float)
    assert content["kmeans"]["parameters"]["seed"] == 3


def test_a_read_option_of_the_wrong_type_leaves_no_output(tmp_path: Path) -> None:
    with pytest.raises(OptionError):
        analyze(LOG, MODEL, out_dir=tmp_path / "r", read=ReadOptions(sort="no"))  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == []
