"""One ReadOptions, checked when built; the SignalSpec of a model."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest

from hybridlog.cli import main
from hybridlog.errors import OptionError
from hybridlog.io import ReadOptions, SignalSpec
from hybridlog.model.loader import load_model
from tests.support.paths import TANK_CSV

SAMPLE = TANK_CSV


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"time": "wall"}, "--time: expected one of log, header, got 'wall'"),
        (
            {"resample": "cubic"},
            "--resample: unknown method 'cubic'; choose one of nearest, linear",
        ),
        ({"max_gap": -1.0}, "--max-gap: must be between 0 and 1e+09 seconds, got -1"),
        ({"max_gap": math.nan}, "--max-gap: must be between 0 and 1e+09 seconds, got nan"),
        ({"max_gap": math.inf}, "--max-gap: must be between 0 and 1e+09 seconds, got inf"),
        # its nanoseconds overflowed int64 in the alignment
        ({"max_gap": 1e300}, "--max-gap: must be between 0 and 1e+09 seconds, got 1e+300"),
    ],
)
def test_bad_values_are_refused_when_built(values: dict[str, object], message: str) -> None:
    with pytest.raises(OptionError) as error:
        ReadOptions(**values)  # type: ignore[arg-type]
    assert str(error.value) == message


def test_good_values_and_defaults() -> None:
    assert ReadOptions() == ReadOptions(
        maps=(), resample="nearest", max_gap=None, time="log", msg_dirs=()
    )
    options = ReadOptions(resample="linear", max_gap=0.0, time="header", sort=True)
    assert (options.resample, options.max_gap, options.time, options.sort) == (
        "linear",
        0.0,
        "header",
        True,
    )
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.sort = False  # type: ignore[misc]


def test_the_command_line_builds_the_checked_options(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "report"
    args = ["analyze", str(SAMPLE), "--model", "three_tank_hstf", "--out", str(out)]
    with pytest.raises(SystemExit) as exit_:
        main([*args, "--max-gap", "-2"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    # refused as the line is parsed, a usage error like any other bad number
    assert err == (
        "hybridlog analyze: --max-gap: expected a number from 0 to 1e+09, got -2 "
        "(see hybridlog analyze --help)\n"
    )
    assert not out.exists()


def test_signal_spec_of_a_model() -> None:
    model = load_model("three_tank_hstf")
    spec = SignalSpec.of(model)
    assert (spec.inputs, spec.outputs, spec.states) == (model.inputs, model.outputs, model.states)
    assert (spec.mode_ids, spec.dt) == (model.mode_ids, model.dt)
    assert dict(spec.signals) == model.signals and dict(spec.truth) == model.truth
    with pytest.raises(TypeError):
        spec.signals["u"] = "/other.data"  # type: ignore[index]


def test_a_msg_dir_that_is_no_folder_is_refused_whatever_the_log(tmp_path) -> None:
    # a CSV or Parquet log never reads --msg-dir: a mistyped folder was ignored without a word
    with pytest.raises(OptionError, match=r"^--msg-dir .*nope: no such folder$"):
        ReadOptions(msg_dirs=(str(tmp_path / "nope"),))
    afile = tmp_path / "a.msg"
    afile.write_text("float64 x\n")
    with pytest.raises(OptionError, match=r"a file, not a folder of \.msg files$"):
        ReadOptions(msg_dirs=(str(afile),))
    assert ReadOptions(msg_dirs=(str(tmp_path),)).msg_dirs == (str(tmp_path),)


@pytest.mark.parametrize(
    ("path", "options", "shown"),
    [
        (None, None, r"log: expected a path \(a str or pathlib.Path\), got the NoneType 'None'"),
        ("", None, "log: expected a path .* got the str ''"),
        (TANK_CSV, {"maps": ()}, "read: expected a hybridlog.io.ReadOptions or None, got the dict"),
    ],
)
def test_reading_a_log_refuses_arguments_of_the_wrong_type(path, options, shown):
    # load_signals and inspect_log let Python's TypeError (a None path) and AttributeError
    # (a dict of options: no attribute 'resample') through
    from hybridlog.io import inspect_log, load_signals

    spec = SignalSpec.of(load_model("three_tank_hstf"))
    with pytest.raises(OptionError, match=shown):
        load_signals(path, spec, options)
    with pytest.raises(OptionError, match=shown):
        inspect_log(path, options)


def test_a_msg_dir_or_centres_file_that_is_a_link_loop_is_said_so(tmp_path) -> None:
    # --msg-dir LOOP said "no such folder"; --set centers=LOOP "cannot read: [Errno 40] ..."
    from hybridlog.jobs.centers import read_centers

    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    loop = r"\(Too many levels of symbolic links\)$"
    with pytest.raises(OptionError, match=rf"/a: a symbolic link that cannot be followed {loop}"):
        ReadOptions(msg_dirs=(str(tmp_path / "a"),))
    with pytest.raises(OptionError, match=rf"/a: cannot be read {loop}"):
        read_centers(tmp_path / "a")
