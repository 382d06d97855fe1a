"""Parquet list, array and struct columns: their numbers named as message paths (SPEC §5).

The logs are written by polars (as pandas and pyarrow write them: ``list<double>``,
``fixed_size_list``, ``struct``), never by hybridlog's own writers.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest

from hybridlog.cli import main
from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, format_inspection, inspect_log, load_signals

N = 12
T = np.round(np.arange(N) * 0.1, 10)
U = np.sin(T)
Y = np.cos(T) * 3


def spec(**changes: Any) -> SignalSpec:
    base: dict[str, Any] = {
        "states": ("x",),
        "inputs": ("u",),
        "outputs": ("y",),
        "mode_ids": ("a", "b"),
        "dt": 0.1,
    }
    return SignalSpec(**{**base, **changes})


def load(path: Path, *maps: str, **changes: Any) -> Any:
    return load_signals(path, spec(**changes), ReadOptions(maps=maps))


def write(tmp_path: Path, columns: dict[str, Any], name: str = "log.parquet") -> Path:
    path = tmp_path / name
    pl.DataFrame(columns).write_parquet(path)
    return path


def vectors(*rows: Any) -> list[list[float]]:
    return [list(map(float, r)) for r in zip(*rows, strict=True)]


def nested_log(tmp_path: Path) -> Path:
    return write(
        tmp_path,
        {
            "t": T,
            "q": vectors(U, Y, np.zeros(N)),
            "f": pl.Series(vectors(Y, U), dtype=pl.Array(pl.Float64, 2)),
            "pose": [{"x": float(a), "y": float(b)} for a, b in zip(U, Y, strict=True)],
            "wheels": [
                [{"speed": float(a)}, {"speed": float(b)}] for a, b in zip(U, Y, strict=True)
            ],
            "status": [{"mode": "a" if k < N // 2 else "b", "x": float(k)} for k in range(N)],
        },
    )


@pytest.mark.parametrize(
    ("u", "y"),
    [
        ("q[0]", "q[1]"),
        ("q[-3]", "q[-2]"),
        ("pose.x", "pose.y"),
        ("pose/x", "pose/y"),  # PlotJuggler's spelling
        ("f[1]", "f[0]"),
        ("f[-1]", "f[-2]"),
        ("wheels[0].speed", "wheels[1].speed"),
    ],
)
def test_list_array_and_struct_fields_are_read_like_message_paths(
    u: str, y: str, tmp_path: Path
) -> None:
    signals = load(nested_log(tmp_path), f"u={u}", f"y={y}")
    np.testing.assert_array_equal(signals.inputs[:, 0], U)
    np.testing.assert_array_equal(signals.outputs[:, 0], Y)


def test_a_struct_field_gives_the_true_mode_and_state(tmp_path: Path) -> None:
    signals = load(
        nested_log(tmp_path),
        "u=q[0]",
        "y=q[1]",
        "truth.mode=status.mode",
        "truth.x=status.x",
    )
    assert signals.truth_modes is not None
    np.testing.assert_array_equal(signals.truth_modes, [0] * (N // 2) + [1] * (N // 2))
    assert signals.truth_states is not None
    np.testing.assert_array_equal(signals.truth_states[:, 0], np.arange(N, dtype=float))


def test_a_flat_column_named_like_a_path_is_that_column(tmp_path: Path) -> None:
    log = write(
        tmp_path,
        {
            "t": T,
            "pose": [{"x": 99.0, "y": 99.0}] * N,
            "pose.x": U,
            "y": Y,
        },
    )
    signals = load(log, "u=pose.x")
    np.testing.assert_array_equal(signals.inputs[:, 0], U)
    assert any("hides the field" in p for p in inspect_log(log)["problems"])


def test_inspect_lists_every_element_and_field(tmp_path: Path) -> None:
    info = inspect_log(nested_log(tmp_path))
    names = [c["name"] for c in info["columns"]]
    assert names == [
        "t",
        "q[0]",
        "q[1]",
        "q[2]",
        "f[0]",
        "f[1]",
        "pose.x",
        "pose.y",
        "wheels[0].speed",
        "wheels[1].speed",
        "status.mode",
        "status.x",
    ]
    q1 = info["columns"][names.index("q[1]")]
    assert q1["dtype"] == "float64" and q1["count"] == N
    assert q1["max"] == pytest.approx(Y.max())
    assert info["problems"] == []
    text = format_inspection(info)
    assert re.search(r"^wheels\[1\]\.speed\s+float64\s+12\b", text, re.M), text


@pytest.mark.parametrize(
    ("u", "words"),
    [
        ("pose", r"'pose' is a struct \(fields 'x', 'y'\); name a field, e\.g\. pose\.x"),
        ("q", r"'q' is a list of float64; add an index, e\.g\. q\[0\]"),
        ("f", r"'f' is an array of 2 float64; add an index, e\.g\. f\[0\]"),
        ("pose.z", r"'pose' has no field 'z'; fields: 'x', 'y'"),
        ("pose[0]", r"'pose' is a struct .*, not a list; name a field"),
        ("q.1", r"'q' is a list of float64; index it, e\.g\. q\[1\]"),
        ("f[2]", r"u=f\[2\]\): index out of range \(the arrays of 'f' hold 2 elements\)"),
        ("q[0].a", r"'q\[0\]' is a float64; it has no \.a"),
        ("wheels[0]", r"'wheels\[0\]' is a struct \(fields 'speed'\); name a field"),
        ("qq[0]", r"closest: 'q\[\]'"),
    ],
)
def test_a_path_that_does_not_fit_the_column_says_why(u: str, words: str, tmp_path: Path) -> None:
    with pytest.raises(LogError, match=words):
        load(nested_log(tmp_path), f"u={u}", "y=q[1]")


def test_an_index_beyond_every_row_s_list_is_refused(tmp_path: Path) -> None:
    with pytest.raises(
        LogError,
        match=r"input 'u' \(column 'q\[3\]', from --map u=q\[3\]\): index out of range "
        r"\(the lists of 'q' hold 3 elements\)",
    ):
        load(nested_log(tmp_path), "u=q[3]", "y=q[1]")


def test_lists_of_different_lengths_are_refused_naming_the_row(tmp_path: Path) -> None:
    rows = vectors(U, Y)
    rows[4] = rows[4][:1]
    log = write(tmp_path, {"t": T, "q": rows})
    message = (
        rf"^{re.escape(str(log))}, row 5, column 'q': 'q' holds 1 elements, but 2 in row 1; "
        r"q\[0\] needs lists of one length in every row"
    )
    with pytest.raises(LogError, match=message):
        load(log, "u=q[0]", "y=q[1]")
    info = inspect_log(log)
    assert [c["name"] for c in info["columns"]] == ["t", "q[]"]
    assert any("hold 1 to 2 elements" in p for p in info["problems"])


def test_a_null_element_inside_a_list_is_refused_naming_the_row(tmp_path: Path) -> None:
    rows: list[list[float | None]] = [list(r) for r in vectors(U, Y)]
    rows[7][1] = None
    log = write(tmp_path, {"t": T, "q": rows})
    with pytest.raises(
        LogError, match=r", row 8, column 'q': 'q\[1\]' is null inside the row's list"
    ):
        load(log, "u=q[0]", "y=q[1]")
    assert any("row 8, column 'q'" in p for p in inspect_log(log)["problems"])


def test_an_empty_cell_of_a_list_column_is_no_sample(tmp_path: Path) -> None:
    """A list column written at half the rate: its empty cells are not samples."""
    rows: list[list[float] | None] = list(vectors(U, Y))
    for k in range(1, N, 2):
        rows[k] = None
    log = write(tmp_path, {"t": T, "u": U, "q": rows})
    signals = load_signals(log, spec(dt=0.2), ReadOptions(maps=("y=q[1]",), resample="linear"))
    np.testing.assert_allclose(signals.outputs[:, 0], Y[::2])


def test_a_null_struct_field_is_no_sample_of_it(tmp_path: Path) -> None:
    pose = [
        {"x": float(a), "y": float(b) if k % 2 == 0 else None}
        for k, (a, b) in enumerate(zip(U, Y, strict=True))
    ]
    log = write(tmp_path, {"t": T, "pose": pose})
    signals = load_signals(log, spec(dt=0.2), ReadOptions(maps=("u=pose.x", "y=pose.y")))
    np.testing.assert_array_equal(signals.outputs[:, 0], Y[::2])


def test_a_text_list_element_is_refused_as_a_number(tmp_path: Path) -> None:
    log = write(tmp_path, {"t": T, "names": [["a", "b"]] * N, "y": Y})
    with pytest.raises(LogError, match=r"column 'names\[0\]' has type String, expected a number"):
        load(log, "u=names[0]")


def test_cli_refuses_a_ragged_list_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rows = vectors(U, Y)
    rows[2] = [*rows[2], 0.0]
    log = write(tmp_path, {"t": T, "q": rows})
    model = tmp_path / "m.toml"
    model.write_text(
        'name = "m"\ntime = "discrete"\ndt = 0.1\nstates = ["x"]\ninputs = ["u"]\n'
        'outputs = ["y"]\n[modes.a]\nf = "x + u"\nh = "x"\n[noise]\nprocess = 1.0\n'
        "measurement = 1.0\n[initial]\nstate = [0.0]\ncovariance = 1.0\n"
    )
    with pytest.raises(SystemExit) as exit_:
        main(
            [
                "analyze",
                str(log),
                "--model",
                str(model),
                "--estimator",
                "imm",
                "--map",
                "u=q[0]",
                "--map",
                "y=q[1]",
                "--out",
                str(tmp_path / "out"),
            ]
        )
    err = capsys.readouterr().err
    assert exit_.value.code == 2
    assert err.count("\n") == 1 and "row 3, column 'q'" in err, err
    assert not (tmp_path / "out").exists()


def test_inspect_lists_a_column_whose_lists_are_all_empty(tmp_path: Path) -> None:
    """A list column whose every list is empty (or an array of width 0) has no element to
    list: inspect left the column out of its table without a word, while analyze's error
    for a path not in the log named it among the columns, ``'lz[]'``."""
    log = write(
        tmp_path,
        {
            "t": T,
            "y": Y,
            "lz": pl.Series([[]] * N, dtype=pl.List(pl.Float64)),
            "az": pl.Series([[]] * N, dtype=pl.Array(pl.Float64, 0)),
        },
    )
    info = inspect_log(log)
    columns = {c["name"]: c for c in info["columns"]}
    assert list(columns) == ["t", "y", "lz[]", "az[]"]
    assert columns["lz[]"]["count"] == N and columns["lz[]"]["nonfinite"] is None
    assert re.search(r"^az\[\]\s+Array\(Float64", format_inspection(info), re.M)
    with pytest.raises(LogError, match=r"the lists of 'lz' hold 0 elements"):
        load(log, "u=lz[0]")
