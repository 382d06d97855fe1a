"""The plots' data reduced chunk by chunk is that of the whole result, small, and drawn alike."""

from __future__ import annotations

import dataclasses
import pickle
import subprocess
import sys
from collections.abc import Iterator
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.background import Worker
from hybridlog.estimators.result import EstimationResult, PostProcessing, TimelineColumn
from hybridlog.report import Report, build_report, pixel_bins
from hybridlog.report.mode_metrics import SwitchDetection
from hybridlog.report.pixel_bins import PixelBins, pixel_columns
from hybridlog.report.plot_data import Components, ModeTimelines, PlotData
from hybridlog.report.plot_reducer import PlotReducer, reduce_result
from hybridlog.report.plots import draw_into, draw_plots, write_plots
from hybridlog.report.timeline_bars import BarsReducer
from hybridlog.signals import NO_TRUE_MODE, AlignedSignals, ComponentTruth

MODES = ("a", "b", "c")
STATES = ("x1", "x2", "x3")
OUTPUTS = ("y1", "y2")
LABELS = ("m1", "m2", "unknown")
TRUE_LABELS = ("m2", "m0", "m1")


def _modes(rng: np.random.Generator, n: int, n_modes: int) -> np.ndarray:
    """A mode sequence of runs from 1 to 400 samples long."""
    lengths = rng.choice([1, 2, 3, 40, 400], size=n // 2 + 1)
    return np.repeat(rng.integers(0, n_modes, lengths.size), lengths)[:n].astype(np.int64)


def _walk(rng: np.random.Generator, n: int, k: int) -> np.ndarray:
    return np.cumsum(rng.standard_normal((n, k)), axis=0)


def _estimate(
    rng: np.random.Generator,
    time: np.ndarray,
    outputs: tuple[str, ...] = OUTPUTS,
    *,
    components: bool = False,
    spike: float = np.inf,
) -> EstimationResult:
    n = time.shape[0]
    probabilities = rng.random((n, len(MODES)))
    probabilities /= probabilities.sum(axis=1, keepdims=True)
    variances = rng.normal(1.0, 0.6, (n, len(STATES)))  # some negative: clipped
    variances[rng.random((n, len(STATES))) < 0.05] = np.nan
    variances[:, 2] = np.nan  # a state without a variance: no band
    predictions = _walk(rng, n, len(outputs))
    predictions[:1] = np.nan  # row 0 of a prediction
    predictions[rng.random((n, len(outputs))) < 0.01] = spike  # not finite: left out of min/max
    columns = (
        (
            TimelineColumn("mode.A", _modes(rng, n, len(LABELS)), LABELS),
            TimelineColumn("mode.B", _modes(rng, n, 2), LABELS[:2]),
            TimelineColumn("delta.d1", rng.random(n)),  # not a component's
        )
        if components
        else ()
    )
    return EstimationResult(
        estimator="test",
        options={},
        time=time,
        mode_ids=MODES,
        state_names=STATES,
        output_names=outputs,
        modes=_modes(rng, n, len(MODES)),
        mode_probabilities=probabilities,
        state_means=_walk(rng, n, len(STATES)),
        state_variances=variances,
        output_predictions=predictions,
        timeline_columns=columns,
    )


def _run(
    n: int,
    seed: int,
    *,
    smoothed: bool = False,
    components: bool = False,
    truth: bool = True,
    mode_sequence: str = "argmax",
    spike: float = np.inf,
) -> tuple[EstimationResult, AlignedSignals]:
    """A result and its signals, built from random arrays (no filter runs).

    ``spike``: the non-finite predictions (matplotlib's autoscaling overflows on infinite
    values: NaN for a run that is drawn).
    """
    rng = np.random.default_rng(seed)
    time = 3.0 + np.cumsum(rng.uniform(0.2, 1.8, n))  # uneven: bins of different sizes
    result = _estimate(rng, time, components=components, spike=spike)
    if smoothed:
        filtered = _estimate(rng, time, components=components, spike=spike)
        post = PostProcessing("kim-rts", mode_sequence, "test", filtered)
        result = dataclasses.replace(result, post_processing=post)
    states = _walk(rng, n, len(STATES))
    states[:, 1] = np.nan  # a state the log does not have
    signals = AlignedSignals(
        source="test",
        time=time,
        input_names=(),
        output_names=OUTPUTS,
        inputs=np.zeros((n, 0)),
        outputs=_walk(rng, n, len(OUTPUTS)),
        truth_modes=_modes(rng, n, len(MODES)) if truth else None,
        state_names=STATES,
        truth_states=states if truth else None,
        # component A's true modes: one label its column lacks; component B has none
        truth_components={"A": ComponentTruth(TRUE_LABELS, _modes(rng, n, len(TRUE_LABELS)))}
        if truth and components
        else {},
    )
    return result, signals


def _rows(result: EstimationResult, start: int, stop: int) -> EstimationResult:
    """Rows ``start:stop`` of a result, copied (as a streamed estimator's chunk)."""
    post = result.post_processing
    return dataclasses.replace(
        result,
        time=result.time[start:stop].copy(),
        modes=result.modes[start:stop].copy(),
        mode_probabilities=result.mode_probabilities[start:stop].copy(),
        state_means=result.state_means[start:stop].copy(),
        state_variances=result.state_variances[start:stop].copy(),
        output_predictions=result.output_predictions[start:stop].copy(),
        timeline_columns=tuple(
            dataclasses.replace(c, values=c.values[start:stop].copy())
            for c in result.timeline_columns
        ),
        post_processing=None
        if post is None
        else dataclasses.replace(post, filtered=_rows(post.filtered, start, stop)),
    )


def _overwrite(chunk: EstimationResult) -> None:
    """What the next chunk does to this one's arrays."""
    for array in (
        chunk.time,
        chunk.mode_probabilities,
        chunk.state_means,
        chunk.state_variances,
        chunk.output_predictions,
    ):
        array.fill(-1e300)
    chunk.modes.fill(0)
    for column in chunk.timeline_columns:
        column.values.fill(0)
    if chunk.post_processing is not None:
        _overwrite(chunk.post_processing.filtered)


def _cuts(n: int, rng: np.random.Generator) -> list[int]:
    """Chunk boundaries: runs of 1-row chunks, short chunks and long ones, in random order."""
    cuts = [0]
    while cuts[-1] < n:
        kind = rng.integers(0, 3)
        if kind == 0:
            cuts.extend(cuts[-1] + 1 + np.arange(rng.integers(1, 5)))
        else:
            cuts.append(cuts[-1] + int(rng.integers(2, 30 if kind == 1 else 6_000)))
    return [*(c for c in cuts if c < n), n] if n else [0, 0]


def _chunked(result: EstimationResult, signals: AlignedSignals, cuts: list[int]) -> PlotData:
    reducer = PlotReducer(signals, result.mode_ids, result.state_names, result.output_names)
    for start, stop in pairwise(cuts):
        chunk = _rows(result, start, stop)
        reducer.add(chunk, start)
        _overwrite(chunk)
    return reducer.finish()


def _leaves(value: Any, path: str = "data") -> Iterator[tuple[str, Any]]:
    """Every array, string and number of a PlotData, by where it is."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
    elif isinstance(value, tuple) and hasattr(value, "_fields"):
        value = value._asdict()
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _leaves(item, f"{path}.{key}")
    elif isinstance(value, tuple):
        yield f"{path}:len", len(value)
        for i, item in enumerate(value):
            yield from _leaves(item, f"{path}[{i}]")
    else:
        yield path, value


def assert_same(a: PlotData, b: PlotData) -> None:
    left, right = list(_leaves(a)), list(_leaves(b))
    assert [p for p, _ in left] == [p for p, _ in right]
    for (path, x), (_, y) in zip(left, right, strict=True):
        if isinstance(x, np.ndarray):
            assert isinstance(y, np.ndarray) and x.dtype == y.dtype, path
            np.testing.assert_array_equal(x, y, err_msg=path)
        else:
            assert type(x) is type(y) and x == y, path


KINDS = {
    "plain": {},
    "smoothed": {"smoothed": True},
    "viterbi": {"smoothed": True, "mode_sequence": "viterbi"},
    "components": {"components": True},
    "components kbest": {"components": True, "smoothed": True, "mode_sequence": "kbest"},
    "no truth": {"truth": False},
}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("n", [1, 2, 57, 3_000, 3_561, 40_009])
def test_chunks_give_the_data_of_the_whole_result(kind: str, n: int) -> None:
    result, signals = _run(n, seed=n, **KINDS[kind])
    whole = reduce_result(result, signals)
    reduced = n > 4 * pixel_columns()
    assert all(curves.predicted.reduced == reduced for curves in whole.outputs)
    for seed in range(3):
        cuts = _cuts(n, np.random.default_rng(seed))
        assert_same(_chunked(result, signals, cuts), whole)
    modes = whole.modes
    if kind.startswith("components"):
        assert isinstance(modes, Components)
        assert [c.name for c in modes.columns] == ["A", "B"]
        a, b = modes.columns
        assert a.labels == (*LABELS, "m0") and b.labels == LABELS[:2]
        assert a.truth is not None and b.truth is None
        post = result.post_processing
        if post is None:
            assert modes.joint_ids == tuple(MODES[m] for m in np.unique(result.modes))
            assert modes.label == "estimated" and modes.joint_filtered is None
            assert a.filtered is None and b.filtered is None
        else:
            both = np.union1d(result.modes, post.filtered.modes)
            assert modes.joint_ids == tuple(MODES[m] for m in both)
            assert modes.label == "kbest" and modes.joint_filtered is not None
            assert a.filtered is not None and b.filtered is not None
    else:
        assert isinstance(modes, ModeTimelines)
        assert modes.label == {"smoothed": "smoothed", "viterbi": "viterbi"}.get(kind, "estimated")
        assert (modes.filtered is not None) == (kind in ("smoothed", "viterbi"))
        assert (modes.truth is None) == (kind == "no truth")


@pytest.mark.parametrize("block", [7, 1 << 16])
def test_blocks_inside_a_chunk_give_the_same_data(
    block: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    result, signals = _run(20_011, seed=4, smoothed=True)
    whole = reduce_result(result, signals)
    monkeypatch.setattr(pixel_bins, "BLOCK", block)  # every reduction's blocks
    assert_same(_chunked(result, signals, [0, 1, 9_000, 9_001, 20_011]), whole)


@pytest.mark.parametrize("kind", ["smoothed", "components", "components kbest", "no truth"])
def test_the_pngs_drawn_from_chunks_are_those_of_the_whole_result(
    kind: str, tmp_path: Path
) -> None:
    result, signals = _run(40_009, seed=11, spike=np.nan, **KINDS[kind])
    whole, chunked = tmp_path / "whole", tmp_path / "chunked"
    whole.mkdir()
    chunked.mkdir()
    written = write_plots(whole, result, signals)
    assert [p.name for p in written] == ["outputs.png", "modes.png", "states.png"]
    data = _chunked(result, signals, _cuts(result.n_samples, np.random.default_rng(1)))
    draw_plots(chunked, pickle.loads(pickle.dumps(data)))  # as another process receives it
    worker = Worker("test-plots")  # as the plots' worker draws them: states.png in a fork
    try:
        drawn = worker.submit(draw_into, tmp_path / "worker", data).result()
    finally:
        worker.close()
    assert [p.name for p in drawn] == ["outputs.png", "modes.png", "states.png"]
    for name in ("outputs.png", "modes.png", "states.png"):
        assert (chunked / name).read_bytes() == (whole / name).read_bytes(), name
        assert (tmp_path / "worker" / name).read_bytes() == (whole / name).read_bytes(), name


def test_a_components_result_shows_its_truth_and_its_filters_modes() -> None:
    """Each component's bars: the estimate's, the log's true modes (relabelled into the
    component's rows, a true label the column lacks added) and the causal filter's own."""
    result, signals = _run(3_000, seed=5, smoothed=True, components=True, mode_sequence="kbest")
    data = reduce_result(result, signals)
    assert isinstance(data.modes, Components)
    a, b = data.modes.columns
    bins = PixelBins.of_run(signals.time)

    def bars(codes: np.ndarray, n_labels: int) -> Any:
        reducer = BarsReducer(bins, n_labels)
        reducer.add(codes, 0)
        return reducer.finish()

    rows = np.array([a.labels.index(label) for label in TRUE_LABELS])
    expected = {
        "A truth": bars(rows[signals.truth_components["A"].codes], 4),
        "A filtered": bars(result.post_processing.filtered.timeline_columns[0].values, 4),
        "B filtered": bars(result.post_processing.filtered.timeline_columns[1].values, 2),
        "A": bars(result.timeline_columns[0].values, 4),
    }
    got = {"A truth": a.truth, "A filtered": a.filtered, "B filtered": b.filtered, "A": a.bars}
    for name, want in expected.items():
        for (first, last), (g_first, g_last) in zip(want, got[name], strict=True):
            np.testing.assert_array_equal(g_first, first, err_msg=name)
            np.testing.assert_array_equal(g_last, last, err_msg=name)


def test_a_component_whose_true_mode_starts_late_is_scored_and_drawn_from_it_on() -> None:
    """Before a component's first true-mode sample its codes are NO_TRUE_MODE (-1): as an
    index into the labels it would draw and score the last label there.  The truth's bars
    start where it does, its report scores the samples from there (modes.components.A
    .samples), the joint accuracy the samples where every component has a true mode."""
    result, signals = _run(600, seed=5, components=True)
    start = 200
    codes = signals.truth_components["A"].codes.copy()
    codes[:start] = NO_TRUE_MODE
    late = dataclasses.replace(signals, truth_components={"A": ComponentTruth(TRUE_LABELS, codes)})
    data = reduce_result(result, late)
    assert isinstance(data.modes, Components)
    a = data.modes.columns[0]
    assert a.truth is not None
    first_bin = PixelBins.of_run(signals.time).spanned(start, 1)[0]
    assert min(int(first.min()) for first, _ in a.truth if first.size) == first_bin
    report = build_report(result, late, log="l", model_name="m", dt=1.0)
    component = report.modes.components["A"]
    assert component.samples == 600 - start
    alone = build_report(
        result.rows(start, 600),
        dataclasses.replace(
            signals.rows(start, 600),
            truth_components={"A": ComponentTruth(TRUE_LABELS, codes[start:])},
        ),
        log="l", model_name="m", dt=1.0,
    )  # fmt: skip
    scored = alone.modes.components["A"]  # the estimate's switches and dwell stay the run's
    assert (component.accuracy, component.confusion) == (scored.accuracy, scored.confusion)
    assert component.detection is not None and scored.detection is not None

    def measured(events: tuple[SwitchDetection, ...]) -> list[tuple[object, ...]]:
        # a miss's reason names since when the estimate sat in the mode: the run's estimate
        # may have sat there from before the truth starts, which the cut rows cannot say
        return [(e.t, e.from_mode, e.to_mode, e.detected_t, e.delay_s) for e in events]

    assert measured(component.detection.events) == measured(scored.detection.events)
    # component B has no truth: no joint accuracy, as before
    assert report.modes.accuracy is None and report.modes.samples is None
    assert Report.from_dict(report.to_dict(), source="r").modes == report.modes


def test_the_data_of_a_million_samples_is_small() -> None:
    n, chunk, outputs = 1_000_000, 65_536, ("y1", "y2", "y3")
    rng = np.random.default_rng(0)
    time = np.arange(n) * 0.01
    signals = AlignedSignals(
        source="test",
        time=time,
        input_names=(),
        output_names=outputs,
        inputs=np.zeros((n, 0)),
        outputs=rng.standard_normal((n, 3)),
        truth_modes=_modes(rng, n, len(MODES)),
        state_names=STATES,
        truth_states=rng.standard_normal((n, 3)),
    )
    reducer = PlotReducer(signals, MODES, STATES, outputs)
    for start in range(0, n, chunk):  # the whole run is never in memory
        rows = time[start : start + chunk]
        post = PostProcessing("kim-rts", "argmax", "test", _estimate(rng, rows, outputs))
        estimate = dataclasses.replace(_estimate(rng, rows, outputs), post_processing=post)
        reducer.add(estimate, start)
    data = reducer.finish()
    assert len(pickle.dumps(data)) < 1_000_000
    arrays = [value for _, value in _leaves(data) if isinstance(value, np.ndarray)]
    assert max(a.size for a in arrays) <= 4 * pixel_columns()


def test_no_samples_and_chunks_out_of_order(tmp_path: Path) -> None:
    result, signals = _run(0, seed=0)
    data = reduce_result(result, signals)
    assert data.modes is None and data.span is None
    assert_same(PlotReducer(signals, MODES, STATES, OUTPUTS).finish(), data)
    assert len(draw_plots(tmp_path, data)) == 3

    result, signals = _run(100, seed=1, smoothed=True)
    reducer = PlotReducer(signals, MODES, STATES, OUTPUTS)
    with pytest.raises(ValueError, match=r"rows \[10, 20\) added where row 0 of 100"):
        reducer.add(_rows(result, 10, 20), 10)
    reducer.add(_rows(result, 0, 10), 0)
    with pytest.raises(ValueError, match=r"rows \[10, 101\) added where row 10 of 100"):
        reducer.add(_rows(result, 0, 91), 10)
    with pytest.raises(ValueError, match="post-processing where the first chunk"):
        reducer.add(dataclasses.replace(_rows(result, 10, 20), post_processing=None), 10)
    with pytest.raises(ValueError, match=r"rows \[10, 100\) of the result were not added"):
        reducer.finish()


def test_the_reduction_imports_no_matplotlib() -> None:
    code = "import sys, hybridlog.report.plot_reducer; print('matplotlib' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"


def test_a_components_modes_png_keeps_its_labels_and_title_inside(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """bioplex's modes.png (unknown-mode --mode-sequence kbest): the modes of a component
    (``one_bank_out``), the component's name and the joint assignments
    (``partly_open|partly_open|closed|closed|full|growth``) were cut off at the figure's
    left edge, and the title of the tall figure ran into its first panel."""
    from hybridlog.report import mode_plots, plot_figures

    result, signals = _run(3_000, seed=5, smoothed=True, components=True, mode_sequence="kbest")
    data = reduce_result(result, signals)
    assert isinstance(data.modes, Components)
    long = "partly_open|partly_open|closed|closed|one_bank_out|growth"
    columns = tuple(  # panels enough for a figure as tall as bioplex's
        c._replace(
            name=f"component_{c.name}{k}", labels=tuple(f"{x}_one_bank_out" for x in c.labels)
        )
        for k in range(6)
        for c in data.modes.columns
    )
    joint_ids = tuple(f"{long}_{j}" for j in data.modes.joint_ids)
    data = dataclasses.replace(
        data, modes=data.modes._replace(columns=columns, joint_ids=joint_ids)
    )
    drawn: list[Any] = []
    save = plot_figures.save
    monkeypatch.setattr(
        mode_plots, "save", lambda fig, path: (drawn.append(fig), save(fig, path))[1]
    )
    mode_plots.plot_modes(data, tmp_path / "modes.png")
    (fig,) = drawn
    renderer = fig.canvas.get_renderer()
    texts = [
        text
        for ax in fig.axes
        for text in (*ax.get_yticklabels(), ax.yaxis.label)
        if text.get_text()
    ]
    assert len(texts) >= len(joint_ids) + 3
    for text in texts:
        assert text.get_window_extent(renderer).x0 >= 0.0, text.get_text()
    title = fig._suptitle.get_window_extent(renderer)
    top = max(ax.get_window_extent(renderer).y1 for ax in fig.axes)
    assert title.y0 > top and title.y1 <= fig.bbox.height
