"""Alignment onto the model grid: exactness on grid, multi-rate rules, gaps."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from hybridlog.errors import LogError, OptionError
from hybridlog.io import ReadOptions, SignalSpec, load_signals, write_table
from hybridlog.io.align import align_signals
from hybridlog.io.source import LabelSeries, Series, format_ns, ns_to_seconds, seconds_to_ns
from hybridlog.signals import MAX_MAGNITUDE, NO_TRUE_MODE

ArrayLike = np.ndarray | list[float]


def series(name: str, seconds: ArrayLike, values: ArrayLike) -> Series:
    return Series(
        name,
        seconds_to_ns(np.asarray(seconds, dtype=np.float64)),
        np.asarray(values, dtype=np.float64),
    )


def test_seconds_to_ns_and_format() -> None:
    np.testing.assert_array_equal(
        seconds_to_ns(np.array([0.0, 0.1, 0.30000000000000004, -1.5, 1.7e9 + 0.25])),
        [0, 100_000_000, 300_000_000, -1_500_000_000, 1_700_000_000_250_000_000],
    )
    assert format_ns(1_500_000_000) == "1.5"
    assert format_ns(-250_000_000) == "-0.25"
    assert format_ns(3_000_000_000) == "3"


def test_on_grid_csv_is_reproduced_bit_for_bit(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    n = 1000
    # Every magnitude hybridlog accepts (|v| < 2**480 ≈ 3.1e144; larger ones are refused
    # since issue 7, see test_io_tables.py), from subnormal up to just below that bound.
    u = rng.normal(size=n) * 10.0 ** rng.integers(-300, 144, size=n)
    y = rng.normal(size=n)
    y[:3] = [-0.0, 5e-324, np.nextafter(MAX_MAGNITUDE, 0.0)]
    path = write_table(tmp_path / "log.csv", {"t": np.arange(n) * 0.01, "u": u, "y": y})
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.01)
    signals = load_signals(path, spec)
    assert signals.n_samples == n
    assert signals.inputs[:, 0].tobytes() == u.tobytes()
    assert signals.outputs[:, 0].tobytes() == y.tobytes()
    np.testing.assert_allclose(signals.time, np.arange(n) * 0.01, rtol=0, atol=1e-12)


@pytest.mark.parametrize("resample", ["nearest", "linear"])
def test_on_grid_epoch_times_are_reproduced(resample: str) -> None:
    # Float seconds near 1.7e9 carry ~0.2 µs of rounding; the samples still count as on grid.
    n = 500
    seconds = 1.7e9 + np.arange(n) * 0.001
    values = np.random.default_rng(3).normal(size=n)
    aligned = align_signals(
        source="epoch",
        dt=0.001,
        inputs={"u": series("u", seconds, values)},
        outputs={"y": series("y", seconds, values[::-1])},
        resample=resample,
    )
    assert aligned.n_samples == n
    assert aligned.inputs[:, 0].tobytes() == values.tobytes()
    assert aligned.outputs[:, 0].tobytes() == values[::-1].tobytes()


@given(
    n=st.integers(min_value=1, max_value=300),
    dt=st.floats(min_value=1e-3, max_value=100.0),
    t0=st.floats(min_value=-1e5, max_value=1e5),
    resample=st.sampled_from(["nearest", "linear"]),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
)
@settings(max_examples=200, deadline=None)
def test_alignment_of_on_grid_data_is_the_identity(
    n: int, dt: float, t0: float, resample: str, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    seconds = t0 + np.arange(n) * dt
    u = rng.normal(size=(n, 2))
    y = rng.normal(size=n)
    aligned = align_signals(
        source="h",
        dt=dt,
        inputs={"u1": series("u1", seconds, u[:, 0]), "u2": series("u2", seconds, u[:, 1])},
        outputs={"y": series("y", seconds, y)},
        resample=resample,
    )
    assert aligned.n_samples == n
    assert aligned.inputs.tobytes() == np.ascontiguousarray(u).tobytes()
    assert aligned.outputs[:, 0].tobytes() == y.tobytes()
    np.testing.assert_allclose(aligned.time, seconds, rtol=1e-12, atol=1e-8)


def multi_rate(tmp_path: Path) -> Path:
    """Input u = k at 10 Hz (t = k/10), output y = j at 3 Hz (t = j/3), both on 0..3 s."""
    u_times = [k / 10 for k in range(31)]
    y_times = [j / 3 for j in range(10)]
    times = sorted(set(u_times) | set(y_times))
    lines = ["t,u,y"]
    for t in times:
        u = str(u_times.index(t)) if t in u_times else ""
        y = str(y_times.index(t)) if t in y_times else ""
        lines.append(f"{t!r},{u},{y}")
    path = tmp_path / "multi.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_multi_rate_nearest_by_hand(tmp_path: Path) -> None:
    signals = load_signals(
        multi_rate(tmp_path), SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.5)
    )
    # Grid 0, 0.5, ..., 3.0 (the last output sample is at 3.0).
    np.testing.assert_array_equal(signals.time, [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0])
    # Zero-order hold of u = k at t = k/10: the sample at t_k itself.
    np.testing.assert_array_equal(signals.inputs[:, 0], [0, 5, 10, 15, 20, 25, 30])
    # Nearest y: 0.5 lies 1/6 s from y(1/3) = 1 and y(2/3) = 2, a tie that goes to the
    # earlier sample; 1.0 = 3/3 is a sample; 1.5 ties between 4/3 and 5/3 -> 4; and so on.
    np.testing.assert_array_equal(signals.outputs[:, 0], [0, 1, 3, 4, 6, 7, 9])


def test_multi_rate_linear_by_hand(tmp_path: Path) -> None:
    signals = load_signals(
        multi_rate(tmp_path),
        SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.5),
        ReadOptions(resample="linear"),
    )
    # y = 3 t exactly between samples: the midpoints give 1.5, 4.5, 7.5.
    np.testing.assert_allclose(signals.outputs[:, 0], [0, 1.5, 3, 4.5, 6, 7.5, 9], atol=1e-8)
    np.testing.assert_array_equal(signals.inputs[:, 0], [0, 5, 10, 15, 20, 25, 30])


def test_grid_starts_when_every_signal_has_a_value() -> None:
    aligned = align_signals(
        source="s",
        dt=1.0,
        inputs={"u": series("u", [0.0, 1.0, 2.0, 3.0, 4.0], [0, 1, 2, 3, 4])},
        outputs={"y": series("y", [1.5, 2.6, 3.4, 4.5], [15, 26, 34, 45])},
    )
    # t0 = 1.5 (first y); last grid point at most 0.5 s after y's last sample 4.5.
    np.testing.assert_array_equal(aligned.time, [1.5, 2.5, 3.5, 4.5])
    np.testing.assert_array_equal(aligned.inputs[:, 0], [1, 2, 3, 4])
    np.testing.assert_array_equal(aligned.outputs[:, 0], [15, 26, 34, 45])


def test_gap_longer_than_max_gap_names_the_span() -> None:
    seconds = [0.0, 0.5, 1.0, 1.5, 2.0, 5.0, 5.5]
    u = series("u", np.arange(12) * 0.5, np.arange(12))
    y = series("level", seconds, np.arange(7))
    with pytest.raises(LogError) as info:
        align_signals(source="log.csv", dt=0.5, inputs={"u": u}, outputs={"y": y})
    message = str(info.value)
    assert "log.csv" in message
    assert "output 'y'" in message and "'level'" in message
    assert "from t=2 s to t=5 s" in message
    assert "max_gap 2.5 s" in message
    # With a longer max_gap the gap is bridged by the nearest sample (3.5 s is a tie
    # between 2 s and 5 s and goes to the earlier one).
    aligned = align_signals(
        source="log.csv", dt=0.5, inputs={"u": u}, outputs={"y": y}, max_gap=3.0
    )
    np.testing.assert_array_equal(aligned.outputs[:, 0], [0, 1, 2, 3, 4, 4, 4, 4, 5, 5, 5, 6])


def test_short_gap_is_bridged_linearly() -> None:
    u = series("u", np.arange(5) * 1.0, np.zeros(5))
    y = series("y", [0.0, 1.0, 4.0], [0.0, 1.0, 4.0])
    aligned = align_signals(
        source="s", dt=1.0, inputs={"u": u}, outputs={"y": y}, resample="linear"
    )
    np.testing.assert_array_equal(aligned.outputs[:, 0], [0, 1, 2, 3, 4])


def test_max_gap_zero_allows_no_missing_grid_point() -> None:
    u = series("u", np.arange(5) * 1.0, np.zeros(5))
    y = series("y", [0.0, 1.0, 3.0, 4.0], [0.0, 1.0, 3.0, 4.0])
    with pytest.raises(LogError, match="from t=1 s to t=3 s"):
        align_signals(source="s", dt=1.0, inputs={"u": u}, outputs={"y": y}, max_gap=0.0)


def test_truth_mode_is_held_and_truth_states_are_nan_outside() -> None:
    grid = np.arange(6) * 1.0
    mode = LabelSeries(
        "mode",
        seconds_to_ns(np.array([0.2, 2.9])),
        np.array([1, 0], dtype=np.int64),
        ("a", "b"),
    )
    aligned = align_signals(
        source="s",
        dt=1.0,
        inputs={"u": series("u", grid, grid)},
        outputs={"y": series("y", grid, grid)},
        truth_mode=mode,
        states=("x1", "x2"),
        truth_states={"x2": series("x2", [2.0, 3.0], [20.0, 30.0])},
    )
    assert aligned.truth_modes is not None and aligned.truth_states is not None
    # 0.2 s is within half a step of t=0; 2.9 s counts from t=3 on (hold).
    np.testing.assert_array_equal(aligned.truth_modes, [1, 1, 1, 0, 0, 0])
    assert np.isnan(aligned.truth_states[:, 0]).all()
    np.testing.assert_array_equal(
        aligned.truth_states[:, 1], [np.nan, np.nan, 20, 30, np.nan, np.nan]
    )


def test_a_true_mode_starting_late_leaves_the_samples_before_it_without_truth() -> None:
    """A true mode that starts late was an error ('truth.mode starts at t=2 s, after the
    first sample time'), while a true state that starts late is scored over the samples it
    covers.  The samples before the first true-mode sample now have no true mode
    (NO_TRUE_MODE), the rest hold it as before, and where it starts is noted."""
    grid = np.arange(6) * 1.0
    mode = LabelSeries("mode", seconds_to_ns(np.array([2.0, 3.6])), np.array([0, 1]), ("a", "b"))
    notes: dict[str, Any] = {}
    aligned = align_signals(
        source="s", dt=1.0, inputs={"u": series("u", grid, grid)},
        outputs={"y": series("y", grid, grid)}, truth_mode=mode,
        truth_components={"valve": mode}, notes=notes,
    )  # fmt: skip
    late = [NO_TRUE_MODE, NO_TRUE_MODE, 0, 0, 1, 1]  # 3.6 s is within half a step of 4
    assert aligned.truth_modes is not None
    np.testing.assert_array_equal(aligned.truth_modes, late)
    np.testing.assert_array_equal(aligned.truth_components["valve"].codes, late)
    assert notes["truth_starts"] == {
        "mode": {"at": 2.0, "samples": 4, "of": 6},
        "mode.valve": {"at": 2.0, "samples": 4, "of": 6},
    }
    # within half a step of the first sample time it is the nearest sample: no note
    notes = {}
    early = LabelSeries("mode", seconds_to_ns(np.array([0.5])), np.array([1]), ("a", "b"))
    aligned = align_signals(
        source="s", dt=1.0, inputs={"u": series("u", grid, grid)},
        outputs={"y": series("y", grid, grid)}, truth_mode=early, notes=notes,
    )  # fmt: skip
    assert aligned.truth_modes is not None and (aligned.truth_modes == 1).all()
    assert "truth_starts" not in notes


def test_signals_that_do_not_overlap() -> None:
    with pytest.raises(LogError, match="do not overlap"):
        align_signals(
            source="s",
            dt=1.0,
            inputs={"u": series("u", [5.0, 6.0], [0, 0])},
            outputs={"y": series("y", [0.0, 1.0], [0, 0])},
        )


@pytest.mark.parametrize(
    ("options", "pattern"),
    [
        ({"resample": "cubic"}, "--resample: unknown method 'cubic'"),
        ({"max_gap": -1.0}, "--max-gap: must be between 0 and"),
        ({"dt": 0.0}, "dt: the sample time must be between 1e-09 s and"),
        ({"dt": float("nan")}, "dt: the sample time must be between 1e-09 s and"),
    ],
)
def test_bad_options(options: dict[str, object], pattern: str) -> None:
    grid = np.arange(3) * 1.0
    kwargs: dict[str, object] = {
        "source": "s",
        "dt": 1.0,
        "inputs": {"u": series("u", grid, grid)},
        "outputs": {"y": series("y", grid, grid)},
        **options,
    }
    with pytest.raises(OptionError, match=pattern):
        align_signals(**kwargs)  # type: ignore[arg-type]


def test_a_million_rows_align_quickly() -> None:
    n = 1_000_000
    seconds = np.arange(n) * 0.01
    rng = np.random.default_rng(0)
    u, y = series("u", seconds, rng.normal(size=n)), series("y", seconds, rng.normal(size=n))
    start = time.perf_counter()
    aligned = align_signals(source="big", dt=0.01, inputs={"u": u}, outputs={"y": y})
    elapsed = time.perf_counter() - start
    assert aligned.n_samples == n
    assert elapsed < 1.0


def test_split_gaps_analyses_the_longest_piece_and_records_the_pieces() -> None:
    # Output samples every 0.1 s with two long holes: 2.0-3.0 s and 7.0-7.8 s.
    seconds = np.round(np.arange(0.0, 10.01, 0.1), 10)
    keep = ~(((seconds > 2.0) & (seconds < 3.0)) | ((seconds > 7.0) & (seconds < 7.8)))
    y = series("y", seconds[keep], seconds[keep] * 10)
    u = series("u", [0.0, 5.0], [1.0, 2.0])
    with pytest.raises(LogError, match="gap in output 'y'"):
        align_signals(source="s", dt=0.1, inputs={"u": u}, outputs={"y": y}, max_gap=0.5)
    notes: dict[str, object] = {}
    aligned = align_signals(
        source="s",
        dt=0.1,
        inputs={"u": u},
        outputs={"y": y},
        max_gap=0.5,
        split_gaps=True,
        notes=notes,
    )
    assert notes["segments"] == [
        {"start": 0.0, "end": 2.0, "duration": 2.0},
        {"start": 3.0, "end": 7.0, "duration": 4.0},
        {"start": 7.8, "end": 10.0, "duration": pytest.approx(2.2)},
    ]
    assert notes["analysed_segment"] == 1
    np.testing.assert_allclose(aligned.time, np.arange(30, 71) * 0.1)
    np.testing.assert_allclose(aligned.outputs[:, 0], np.arange(30, 71) * 1.0)
    # The input is held across the cut: from 5 s on it is 2.
    np.testing.assert_array_equal(
        aligned.inputs[:, 0], np.where(aligned.time < 5.0 - 1e-9, 1.0, 2.0)
    )


def test_grid_points_bridged_across_short_gaps_are_counted_and_reported() -> None:
    """A log sampled every 1 s on a model of dt 0.37 s: most grid points reuse a sample
    more than dt/2 away (within max_gap), which the report now warns of."""
    from hybridlog.report.reading_notes import report_reading_notes

    y = series("y", np.arange(11) * 1.0, np.arange(11) * 1.0)
    notes: dict[str, object] = {}
    aligned = align_signals(source="s", dt=0.37, inputs={}, outputs={"y": y}, notes=notes)
    far = np.abs(aligned.time - np.round(aligned.time)) > 0.185
    assert notes["bridged"] == {
        "y": {"points": int(far.sum()), "of": aligned.n_samples, "every": 1.0, "steps": 2.7}
    }
    (warning,) = report_reading_notes(notes)
    assert warning.startswith(f"WARNING: output y has no sample within dt/2 of {int(far.sum())} of")
    plain: dict[str, object] = {}
    align_signals(source="s", dt=1.0, inputs={}, outputs={"y": y}, notes=plain)
    assert plain == {} and report_reading_notes(plain) == ()


def test_split_gaps_without_gaps_changes_nothing() -> None:
    y = series("y", np.arange(50) * 0.1, np.arange(50))
    notes: dict[str, object] = {}
    plain = align_signals(source="s", dt=0.1, inputs={}, outputs={"y": y})
    split = align_signals(
        source="s", dt=0.1, inputs={}, outputs={"y": y}, split_gaps=True, notes=notes
    )
    np.testing.assert_array_equal(plain.outputs, split.outputs)
    assert notes == {}


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.integers(-20_000, 20_000), min_size=2, max_size=40),
    st.integers(0, 3),
    st.sampled_from(["nearest", "linear"]),
)
def test_on_grid_shortcut_agrees_with_the_search(
    jitter_ns: list[int], skip: int, resample: str
) -> None:
    # Samples within the clock tolerance (10 µs at dt = 10 ms) of the grid take the shortcut,
    # others the search; both must give what the search alone gives.  (A jittered series,
    # which the hold takes on the grid, is tested on its own below.)
    from hybridlog.io import align as align_module
    from hybridlog.io import resampling, true_modes

    with pytest.MonkeyPatch.context() as monkeypatch:  # undone even where the test fails
        monkeypatch.setattr(align_module, "jittered_index", lambda *args: None)
        monkeypatch.setattr(true_modes, "jittered_index", lambda *args: None)

        n = len(jitter_ns)
        time_ns = np.arange(n, dtype=np.int64) * 10_000_000 + np.array(jitter_ns, dtype=np.int64)
        time_ns[0] = 0
        values = np.arange(n, dtype=np.float64) ** 2
        y = Series(
            "y",
            time_ns[skip:] if skip < n - 1 else time_ns,
            values[skip:] if skip < n - 1 else values,
        )
        u = Series("u", time_ns, values)
        x = Series("x", time_ns[: n // 2 + 1], values[: n // 2 + 1])  # truth that stops early
        common: dict[str, Any] = {
            "inputs": {"u": u},
            "outputs": {"y": y},
            "states": ("x",),
            "truth_states": {"x": x},
            "resample": resample,
        }
        fast = align_signals(source="s", dt=0.01, **common)
        with pytest.MonkeyPatch.context() as patch:  # on_grid's callers: resampling, true_modes
            patch.setattr(resampling, "on_grid", lambda *args: -1)
            patch.setattr(true_modes, "on_grid", lambda *args: -1)
            slow = align_signals(source="s", dt=0.01, **common)
        np.testing.assert_array_equal(fast.time, slow.time)
        np.testing.assert_array_equal(fast.inputs, slow.inputs)
        np.testing.assert_array_equal(fast.outputs, slow.outputs)
        np.testing.assert_array_equal(fast.truth_states, slow.truth_states)  # NaN where it stopped


@pytest.mark.parametrize("late", [True, False])
def test_an_input_on_a_jittering_clock_takes_each_step_s_own_sample(late: bool) -> None:
    """±1 % jitter held about half the inputs from the step before, without a word.

    Recorded once per step with a clock that jitters, the input's sample of step k comes
    sometimes a little before ``t_k``, sometimes a little after; the zero-order hold took
    ``u(k-1)`` for every late one.  Now each step takes its own sample and the notes say so.
    A series whose samples all come late (a constant latency) keeps the hold's delay.
    """
    rng = np.random.default_rng(4)
    n, dt_ns = 200, 10_000_000
    jitter = rng.integers(-100_000, 100_000, n)  # ±1 % of dt
    jitter[0] = 0
    if not late:
        jitter = np.abs(jitter) + 200_000  # all 2-3 % late: the hold's consistent delay
        jitter[0] = 0
    grid = np.arange(n, dtype=np.int64) * dt_ns
    values = np.arange(n, dtype=np.float64) * 3.0
    u = Series("u", grid + jitter, values)
    y = Series("y", grid, values)
    notes: dict[str, Any] = {}
    truth = LabelSeries(
        "mode", grid + jitter, (np.arange(n) // 50).astype(np.int32), ("a", "b", "c", "d")
    )
    aligned = align_signals(
        source="s", dt=0.01, inputs={"u": u}, outputs={"y": y}, truth_mode=truth, notes=notes
    )
    if late:
        np.testing.assert_array_equal(aligned.inputs[:, 0], values)
        np.testing.assert_array_equal(aligned.truth_modes, np.arange(n) // 50)
        assert notes["jitter"] == {
            "input u": pytest.approx(np.abs(jitter).max() / 1e9),
            "the true mode": pytest.approx(np.abs(jitter).max() / 1e9),
        }
    else:
        np.testing.assert_array_equal(aligned.inputs[1:, 0], values[:-1])
        assert "jitter" not in notes


@pytest.mark.parametrize("split_gaps", [False, True])
def test_a_gap_of_exactly_max_gap_is_accepted_at_epoch_times(split_gaps: bool) -> None:
    """Times written to 10 ms at 1.7e9 s: a hole of exactly 5*dt measured up to 190 ns
    longer, and was refused at some places in the log and not at others."""
    epoch = 1_700_000_000.0
    for k in range(4980, 5000):  # 4987 -> 4992 measures 50000190 ns
        steps = [j for j in range(k - 5, k + 10) if not k < j < k + 5]
        seconds = np.array([float(f"{epoch + j * 0.01:.2f}") for j in steps])
        y = series("y", seconds, np.arange(seconds.size))
        notes: dict[str, object] = {}
        aligned = align_signals(
            source="s", dt=0.01, inputs={}, outputs={"y": y}, split_gaps=split_gaps, notes=notes
        )
        assert aligned.n_samples == 15 and "segments" not in notes
    # a gap longer than max_gap by more than the clock's rounding is still one
    y = series("y", [0.0, 0.01, 0.06002, 0.07], [0.0, 1.0, 2.0, 3.0])
    with pytest.raises(LogError, match=r"from t=0\.01 s to t=0\.06002 s"):
        align_signals(source="s", dt=0.01, inputs={}, outputs={"y": y})


@pytest.mark.parametrize("split_gaps", [False, True])
def test_a_signal_without_samples_is_named_by_its_symbol(split_gaps: bool) -> None:
    """'log.bag: '/level.data' has no samples' did not say which symbol needed it."""
    u = series("u", [0.0, 1.0, 2.0], [1.0, 2.0, 3.0])
    empty = series("/level.data", [], [])
    with pytest.raises(LogError) as error:
        align_signals(
            source="log.bag",
            dt=1.0,
            inputs={"u": u},
            outputs={"y": empty},
            split_gaps=split_gaps,
            field_word="field",
        )
    assert str(error.value) == "log.bag: output 'y' (field '/level.data') has no samples"
    with pytest.raises(LogError) as error:
        align_signals(source="log.csv", dt=1.0, inputs={"u": empty}, outputs={"y": u})
    assert str(error.value) == "log.csv: input 'u' (column '/level.data') has no samples"


def test_an_output_slower_than_max_gap_says_so() -> None:
    """A log at 1 s on a model of dt 0.1 s was 'gap ... from t=0 s to t=1 s', and with
    --split-gaps 'too short: 1 sample' (every step was a gap, every piece one sample)."""
    u = series("u", np.arange(20) * 1.0, np.arange(20))
    y = series("y", np.arange(20) * 1.0, np.arange(20))
    hint = (
        "; it is sampled every 1 s (its median step), slower than max_gap 0.5 s allows: "
        "is the model's dt (0.1 s) the log's?"
    )
    with pytest.raises(LogError) as error:
        align_signals(source="s", dt=0.1, inputs={"u": u}, outputs={"y": y})
    assert str(error.value) == (
        "s: gap in output 'y' (column 'y'): no sample from t=0 s to t=1 s "
        f"(1 s > max_gap 0.5 s){hint}"
    )
    with pytest.raises(LogError) as error:
        align_signals(source="s", dt=0.1, inputs={"u": u}, outputs={"y": y}, split_gaps=True)
    assert str(error.value) == (
        f"s: --split-gaps: output 'y' (column 'y') leaves no piece of more than one sample{hint}"
    )
    # a --max-gap shorter than the log's (and the model's) step: steps of dt are no gaps
    # (the log is read whole without the hole), so the hole alone is named, without the dt
    # hint: the options that take a log with a hole are named instead
    remedy = (
        "; --max-gap SECONDS accepts longer gaps, --split-gaps analyses the longest piece "
        "between them"
    )
    seconds = np.delete(np.arange(20) * 1.0, [5, 6, 7])
    holed_at_dt = series("y", seconds, seconds)
    with pytest.raises(LogError) as error:
        align_signals(source="s", dt=1.0, inputs={"u": u}, outputs={"y": holed_at_dt}, max_gap=0.5)
    assert str(error.value).endswith(f"(4 s > max_gap 0.5 s){remedy}")
    # a log at the model's rate with one hole gets no dt hint
    holed = series("y", np.delete(np.arange(200) * 0.1, range(50, 60)), np.arange(190))
    with pytest.raises(LogError) as error:
        align_signals(source="s", dt=0.1, inputs={"u": u}, outputs={"y": holed})
    assert str(error.value).endswith(f"(1.1 s > max_gap 0.5 s){remedy}")


def test_a_log_in_nanoseconds_is_refused_before_its_grid_is_made(monkeypatch) -> None:
    """Times in ns read as seconds (50 rows from 0) asked numpy for a grid of 365 GiB and
    ended as 'out of memory in align.py'; the gap is now seen before the grid is made."""
    import hybridlog.io.align as align

    def no_grid(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("the grid was made before the gap was seen")

    monkeypatch.setattr(align, "grid_between", no_grid)
    stamps = np.arange(50) * 100_000_000.0  # nanoseconds, taken as seconds
    with pytest.raises(
        LogError,
        match=r"gap in output 'y' \(column 'y'\): no sample from t=0 s to t=100000000 s .*"
        r"Or are its times not in seconds",
    ):
        align_signals(
            source="ns.csv",
            dt=0.1,
            inputs={"u": series("u", stamps, np.zeros(50))},
            outputs={"y": series("y", stamps, np.ones(50))},
        )


@settings(max_examples=300, deadline=None)
@given(
    steps=st.lists(st.integers(1, 40), min_size=2, max_size=30),
    max_gap=st.sampled_from([None, 0.05, 0.1, 0.25, 0.35]),
    start=st.integers(0, 5),
    method=st.sampled_from(["nearest", "linear"]),
)
def test_the_early_gap_check_refuses_only_what_the_grid_check_refuses(
    steps: list[int],
    max_gap: float | None,
    start: int,
    method: str,
) -> None:
    """With the check before the grid, and without it, the same logs are refused or aligned."""
    import hybridlog.io.align as align

    out_times = np.cumsum([0, *steps]) * 0.025  # outputs every 0.025..1 s, dt 0.1
    in_times = np.arange(start, 80) * 0.1

    def run() -> Any:
        try:
            return align_signals(
                source="log",
                dt=0.1,
                inputs={"u": series("u", in_times, np.sin(in_times))},
                outputs={"y": series("y", out_times, np.cos(out_times))},
                resample=method,
                max_gap=max_gap,
            )
        except LogError as err:
            return str(err).split(": no sample")[0]

    early = run()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(align, "gap_on_the_grid", lambda *args: None)
        late = run()
    if isinstance(early, str) or isinstance(late, str):
        assert early == late
    else:
        np.testing.assert_array_equal(early.outputs, late.outputs)
        np.testing.assert_array_equal(early.time, late.time)


def test_the_split_gaps_note_of_a_gap_at_an_end_of_the_log() -> None:
    """A long gap only at an end of the log left one piece, and the note read 'cut the log
    into 1 pieces; ... not analysed: ' with nothing after it."""
    from hybridlog.report.reading_notes import report_reading_notes

    notes = {
        "segments": [{"start": 0.0, "end": 10.0}],
        "analysed_segment": 0,
        "gaps": [{"start": 10.0, "end": 40.0}],
    }
    assert report_reading_notes(notes) == (
        "NOTE: --split-gaps: 1 output gap longer than max_gap (t = 10 … 40 s) left out; "
        "analysed: t = 0 … 10 s",
    )


def test_true_states_bridged_across_short_gaps_are_counted_and_reported() -> None:
    """A true state with a 3 s hole (within max_gap) took its values from the samples around
    it, as an output does, but with no note: the scores against it read as measured."""
    from hybridlog.report.reading_notes import report_reading_notes

    grid = np.arange(11) * 1.0
    kept = np.delete(grid, [4, 5])
    notes: dict[str, object] = {}
    aligned = align_signals(
        source="s",
        dt=1.0,
        inputs={"u": series("u", grid, grid)},
        outputs={"y": series("y", grid, grid)},
        states=("x1", "x2"),
        truth_states={"x1": series("x1", kept, kept), "x2": series("x2", grid, grid)},
        notes=notes,
    )
    assert aligned.truth_states is not None
    # the points without a sample are not the truth: NaN, so no RMSE scores them
    np.testing.assert_array_equal(aligned.truth_states[3:7, 0], [3, np.nan, np.nan, 6])
    assert notes == {"truth_bridged": {"x1": {"points": 2, "of": 11, "every": 1.0, "steps": 1.0}}}
    (warning,) = report_reading_notes(notes)
    assert warning.startswith("WARNING: true state x1 has no sample within dt/2 of 2 of 11")


def test_a_signal_that_ends_the_grid_early_is_named_in_the_reading_notes() -> None:
    """One output ending at 10 s of a 40 s log cut the report's span to 10 s, which read as
    the whole log's; a late start the same (the other end of the grid)."""
    from hybridlog.report.reading_notes import report_reading_notes

    seconds = np.round(np.arange(0.0, 40.01, 0.1), 10)
    early = seconds[seconds <= 10.0]
    late = seconds[seconds >= 2.0]
    notes: dict[str, Any] = {}
    aligned = align_signals(
        source="s",
        dt=0.1,
        inputs={"u": series("cmd", late, late)},
        outputs={"y1": series("y1", seconds, seconds), "y2": series("level", early, early)},
        notes=notes,
        field_word="field",
    )
    assert (aligned.time[0], aligned.time[-1]) == (2.0, 10.0)
    assert notes == {
        "span": {
            "start": {
                "signal": "input 'u' (field 'cmd')",
                "at": 2.0,
                "log": 0.0,
                "left_out": 2.0,
            },
            "end": {
                "signal": "output 'y2' (field 'level')",
                "at": 10.0,
                "log": 40.0,
                "left_out": 30.0,
            },
        }
    }
    assert report_reading_notes(notes) == (
        "NOTE: the analysed span starts at t = 2 s, the first sample of input 'u' (field "
        "'cmd'); the inputs and outputs begin at t = 0 s: 2 s of the log not analysed",
        "NOTE: the analysed span ends at t = 10 s, the last sample of output 'y2' (field "
        "'level'); the inputs and outputs run on to t = 40 s: 30 s of the log not analysed",
    )
    # ends within max_gap of each other: nothing to say
    plain: dict[str, Any] = {}
    near = seconds[(seconds >= 0.3) & (seconds <= 39.5)]
    align_signals(
        source="s",
        dt=0.1,
        inputs={"u": series("cmd", seconds, seconds)},
        outputs={"y1": series("y1", seconds, seconds), "y2": series("level", near, near)},
        notes=plain,
    )
    assert plain == {}


def test_an_input_held_longer_than_max_gap_is_noted_not_refused() -> None:
    """An input whose topic stopped at 10 s while the outputs ran to 40 s was held for 30 s
    without a word; held it stays (SPEC §5: a command published on change is held so), and the
    reading notes the longest hold over max_gap for the report to say."""
    from hybridlog.report.reading_notes import report_reading_notes

    seconds = np.round(np.arange(0.0, 40.01, 0.1), 10)
    y = series("level", seconds, np.cos(seconds))
    on_change = np.array([0.0, 5.0, 6.0, 10.0])  # then silent to the end
    u = series("cmd", on_change, np.array([1.0, 2.0, 3.0, 4.0]))
    notes: dict[str, Any] = {}
    aligned = align_signals(source="log", dt=0.1, inputs={"u": u}, outputs={"y": y}, notes=notes)
    assert aligned.inputs[-1, 0] == 4.0 and aligned.inputs[55, 0] == 2.0
    assert notes["held"] == {
        "u": {"start": 10.0, "end": 40.0, "seconds": 30.0, "holds": 4}
        | {"every": 4.0, "steps": 40.0, "regular": False}  # 3 steps: too few to be regular
    }
    assert report_reading_notes(notes) == (
        "WARNING: input u has no sample in 4 stretches longer than max_gap, the longest from "
        "t = 10 to 40 s (30 s): held at its last value, as an input published only when it "
        "changes is (zero-order hold)",
    )
    notes = {}
    align_signals(
        source="log", dt=0.1, inputs={"u": series("cmd", [0.0, 0.3, 10.0], [1.0, 2.0, 3.0])},
        outputs={"y": y}, notes=notes,
    )  # fmt: skip
    assert notes["held"]["u"]["holds"] == 2 and notes["held"]["u"]["seconds"] == 30.0
    notes = {}
    align_signals(
        source="log", dt=0.1, inputs={"u": series("cmd", [0.0, 0.3, 0.6], [1.0, 2.0, 3.0])},
        outputs={"y": y}, notes=notes,
    )  # fmt: skip
    assert report_reading_notes(notes) == (
        "WARNING: input u has no sample from t = 0.6 to 40 s (39.4 s, longer than max_gap): "
        "held at its last value, as an input published only when it changes is (zero-order "
        "hold)",
    )
    # every hold within max_gap: nothing to say
    notes = {}
    align_signals(
        source="log", dt=0.1, inputs={"u": series("cmd", seconds, seconds)}, outputs={"y": y},
        notes=notes,
    )  # fmt: skip
    assert "held" not in notes


def test_an_input_held_over_many_stretches_is_counted_not_named_as_one_gap() -> None:
    """An input sampled every 10 steps (max_gap 5) read "no sample from t = 290 to 300 s",
    its last hold, as if it had one gap; the note now counts the holds over max_gap."""
    from hybridlog.report.reading_notes import report_reading_notes

    seconds = np.arange(0.0, 301.0)
    y = series("level", seconds, np.cos(seconds))
    u = series("cmd", seconds[::10], seconds[::10])
    truth = LabelSeries(
        "mode", seconds_to_ns(np.array([0.0, 101.0, 201.0])), np.array([0, 1, 0]), ("a", "b")
    )
    notes: dict[str, Any] = {}
    align_signals(
        source="log", dt=1.0, inputs={"u": u}, outputs={"y": y}, truth_mode=truth, notes=notes
    )
    assert notes["held"] == {
        "u": {"start": 290.0, "end": 300.0, "seconds": 10.0, "holds": 30}
        | {"every": 10.0, "steps": 10.0, "regular": True}
    }
    assert notes["truth_held"]["mode"]["holds"] == 3
    said = report_reading_notes(notes)
    assert said[0] == (  # sampled regularly: said so (below), not counted as 30 gaps
        "NOTE: input u is sampled every 10 s (median), 10 steps of dt: held between samples "
        "(zero-order hold)"
    )
    assert said[1].startswith(
        "NOTE: the true mode has no sample in 3 stretches longer than max_gap, the longest "
        "from t = 0 to 101 s (101 s): held"
    )


def test_a_regular_input_slower_than_the_model_is_said_to_be_sampled_so() -> None:
    """A 10 Hz input to a model of dt = 0.01 read "no sample in 100 stretches longer than
    max_gap ... as an input published only when it changes is": it is regular, only slower
    than the model, and is said to be so, at its median step, as a bridged output is; a
    dropout in it is named as its longest hold; one published at irregular times (when it
    changes) keeps the old words, its stretches counted."""
    from hybridlog.report.reading_notes import report_reading_notes

    seconds = np.round(np.arange(0.0, 10.0001, 0.01), 6)
    y = series("level", seconds, np.cos(seconds))
    tenth = np.round(np.arange(0.0, 10.0001, 0.1), 6)
    dropout = np.concatenate([tenth[:40], tenth[60:]])
    on_change = np.sort(np.random.default_rng(1).uniform(0.0, 10.0, 60))
    said = {}
    for name, times in (("u", tenth), ("v", dropout), ("w", on_change)):
        notes: dict[str, Any] = {}
        inputs = {name: series("cmd", times, times)}
        align_signals(source="log", dt=0.01, inputs=inputs, outputs={"y": y}, notes=notes)
        (said[name],) = [n for n in report_reading_notes(notes) if f" {name} " in n]
    assert said["u"] == (
        "NOTE: input u is sampled every 0.1 s (median), 10 steps of dt: held between samples "
        "(zero-order hold)"
    )
    assert said["v"] == (
        "WARNING: input v is sampled every 0.1 s (median), 10 steps of dt, held between samples "
        "(zero-order hold), and its longest stretch without a sample is from t = 3.9 to 6 s "
        "(2.1 s): held at its last value there"
    )
    assert said["w"].startswith("WARNING: input w has no sample in ")
    assert said["w"].endswith(
        "held at its last value, as an input published only when it changes is (zero-order hold)"
    )


def test_a_true_mode_held_longer_than_max_gap_is_noted() -> None:
    """A true mode that stopped at 10 s of a 40 s log was held for 30 s, and the mode accuracy
    scored those samples against the held label without a word; the hold is now noted."""
    from hybridlog.report.reading_notes import report_reading_notes

    seconds = np.round(np.arange(0.0, 40.01, 0.1), 10)
    y = series("level", seconds, np.cos(seconds))
    stopped = LabelSeries(
        "mode", seconds_to_ns(np.array([0.0, 5.0, 10.0])), np.array([0, 1, 0]), ("a", "b")
    )
    notes: dict[str, Any] = {}
    aligned = align_signals(
        source="log", dt=0.1, inputs={"u": series("u", seconds, seconds)}, outputs={"y": y},
        truth_mode=stopped, notes=notes,
    )  # fmt: skip
    assert aligned.truth_modes is not None and aligned.truth_modes[-1] == 0  # still held
    assert notes["truth_held"] == {
        "mode": {"start": 10.0, "end": 40.0, "seconds": 30.0, "holds": 3}
    }
    (note,) = report_reading_notes(notes)
    assert note.startswith(
        "NOTE: the true mode has no sample in 3 stretches longer than max_gap, the longest "
        "from t = 10 to 40 s (30 s): held"
    )
    # sampled with every output sample (as simulate writes it): nothing to say
    notes = {}
    every = LabelSeries("mode", seconds_to_ns(seconds), np.zeros(seconds.size, np.int64), ("a",))
    align_signals(
        source="log", dt=0.1, inputs={"u": series("u", seconds, seconds)}, outputs={"y": y},
        truth_mode=every, notes=notes,
    )  # fmt: skip
    assert "truth_held" not in notes


def test_a_log_at_a_fractional_nanosecond_step_keeps_its_row_count(tmp_path: Path) -> None:
    # dt = 1.5 ns rounds to a 2 ns step, whose half (1 ns) let a 12th grid point at 16.5 ns
    # (rounded to 16) count as within half a step of the last sample at 15 ns.
    n = 11
    path = write_table(
        tmp_path / "log.csv",
        {"t": np.arange(n) * 1.5e-9, "u": np.ones(n), "y": np.arange(n, dtype=np.float64)},
    )
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=1.5e-9)
    signals = load_signals(path, spec)
    assert signals.n_samples == n
    np.testing.assert_array_equal(signals.outputs[:, 0], np.arange(n))


@settings(max_examples=300, deadline=None)
@given(
    step_tenths=st.integers(10, 10_000_000),
    n=st.integers(1, 400),
    t0_ns=st.integers(0, 2_000_000_000_000_000_000),
    outputs=st.booleans(),
)
# dt computed in floating point, 2.4300000000000002e-08 s; the last sample, at 2794.5 ns, is
# rounded down: its grid point is at the bound exactly
@example(step_tenths=243, n=116, t0_ns=0, outputs=False)
def test_the_grid_has_one_point_per_sample_of_a_log_sampled_at_dt(
    step_tenths: int, n: int, t0_ns: int, outputs: bool
) -> None:
    # dt in tenths of a nanosecond, from 1 ns to 1 ms: the log's times are the nearest
    # nanoseconds to k*dt, as a writer at that rate records them.
    from hybridlog.io.time_grid import grid_between, on_whole_ns, step_ns, t0_and_last

    dt = step_tenths * 1e-10
    time_ns = t0_ns + seconds_to_ns(np.arange(n) * dt)
    signal = Series("s", time_ns, np.zeros(n))
    ends = [signal] if outputs else []  # the grid as align_signals makes it
    t0, t_last = t0_and_last([signal], ends, "s", step_ns(dt), on_whole_ns([], dt))
    grid = grid_between(dt, t0, t_last, bool(ends))
    assert grid.size == n
    assert grid[0] == time_ns[0]
    # Never a point more than half a step (plus the nanosecond rounding) past the last sample.
    assert (grid[-1] - time_ns[-1]) <= dt * 5e8 + 0.5


def test_grid_times_at_unix_magnitudes_are_the_floats_nearest_to_them() -> None:
    """``grid / 1e9`` rounded twice (the count to float64, then the quotient): a 100 Hz
    grid from 1.7e9 s had its sample at 1700000001.51 s at 1700000001.5100002 s, in
    report.json's switches and timeline.csv's t column.  Each time is now the float nearest
    to its nanoseconds, which for these is the float of the decimal written."""
    seconds = 1.7e9 + np.arange(300) * 0.01
    aligned = align_signals(
        source="s", dt=0.01, inputs={"u": series("u", seconds, seconds)},
        outputs={"y": series("y", seconds, seconds)},
    )  # fmt: skip
    written = [float(f"{1_700_000_000 + k / 100:.2f}") for k in range(300)]
    assert aligned.time.tolist() == written
    assert ns_to_seconds(np.array([-1_500_000_001, 0, 7])).tolist() == [-1.500000001, 0.0, 7e-9]


def test_small_and_negative_grid_times_are_the_floats_nearest_to_them() -> None:
    """Split into whole seconds and a fraction, small times were rounded twice: a log from
    -100.3 s at 0.5 s had -0.3 s in timeline.csv as -0.30000000000000004 (``-1 + 0.7``), and
    a grid from 0.03 s at 0.1 s its point at 1.93 s as 1.9300000000000002.  A count up to
    ``2**53`` ns is exact in float64: one division rounds it once."""
    for start, dt, n in ((-100.3, 0.5, 400), (0.03, 0.1, 100)):
        written = [round(start + k * dt, 6) for k in range(n)]
        seconds = np.array(written)
        aligned = align_signals(
            source="s", dt=dt, inputs={"u": series("u", seconds, seconds)},
            outputs={"y": series("y", seconds, seconds)},
        )  # fmt: skip
        assert aligned.time.tolist() == written
    counts = np.array([-300_000_000, 1_930_000_000, -(2**53) - 1, 2**53 + 1, 2**62 + 7])
    assert ns_to_seconds(counts).tolist() == [int(c) / 1_000_000_000 for c in counts]
