"""The plots overlay the filter's curve only where the offline pass changed it.

The Viterbi path alone changes only the modes (report.md: "the causal filter's own: the
Viterbi path changes only the modes"), and ``kbest`` without ``smooth`` keeps the filter's
mode probabilities; states.png and modes.png drew those curves a second time, labelled
``filtered``, as if the pass had made other estimates.
"""

from __future__ import annotations

import dataclasses
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from hybridlog.estimators.result import EstimationResult, PostProcessing
from hybridlog.report import plot_figures, plots
from hybridlog.report.plot_data import ModeTimelines
from hybridlog.report.plot_reducer import PlotReducer, reduce_result
from hybridlog.signals import AlignedSignals

N = 500


def _result(rng: np.random.Generator) -> EstimationResult:
    probabilities = rng.random((N, 2))
    probabilities /= probabilities.sum(axis=1, keepdims=True)
    return EstimationResult(
        estimator="test",
        options={},
        time=np.arange(N, dtype=np.float64),
        mode_ids=("a", "b"),
        state_names=("x1", "x2"),
        output_names=("y",),
        modes=rng.integers(0, 2, N).astype(np.int64),
        mode_probabilities=probabilities,
        state_means=np.cumsum(rng.standard_normal((N, 2)), axis=0),
        state_variances=np.ones((N, 2)),
        output_predictions=np.cumsum(rng.standard_normal((N, 1)), axis=0),
    )


def _signals() -> AlignedSignals:
    return AlignedSignals(
        source="test",
        time=np.arange(N, dtype=np.float64),
        input_names=(),
        output_names=("y",),
        inputs=np.zeros((N, 0)),
        outputs=np.zeros((N, 1)),
        truth_modes=np.zeros(N, dtype=np.int64),
        state_names=("x1", "x2"),
        truth_states=np.zeros((N, 2)),
    )


def _offline(filtered: EstimationResult, **changed: np.ndarray) -> EstimationResult:
    """``filtered`` with ``changed`` arrays, and ``filtered`` as its post-processing's."""
    post = PostProcessing(None, "viterbi", "test", filtered)
    return dataclasses.replace(filtered, post_processing=post, **changed)


def _chunked(result: EstimationResult, cuts: list[int]) -> ModeTimelines:
    reducer = PlotReducer(_signals(), result.mode_ids, result.state_names, result.output_names)
    post = result.post_processing
    assert post is not None
    for start, stop in pairwise(cuts):
        rows = slice(start, stop)
        part = dataclasses.replace(
            result,
            time=result.time[rows],
            modes=result.modes[rows],
            mode_probabilities=result.mode_probabilities[rows],
            state_means=result.state_means[rows],
            state_variances=result.state_variances[rows],
            output_predictions=result.output_predictions[rows],
            post_processing=dataclasses.replace(
                post,
                filtered=dataclasses.replace(
                    post.filtered,
                    time=post.filtered.time[rows],
                    modes=post.filtered.modes[rows],
                    mode_probabilities=post.filtered.mode_probabilities[rows],
                    state_means=post.filtered.state_means[rows],
                    state_variances=post.filtered.state_variances[rows],
                    output_predictions=post.filtered.output_predictions[rows],
                ),
            ),
        )
        reducer.add(part, start)
    data = reducer.finish()
    assert isinstance(data.modes, ModeTimelines)
    assert [s.filtered is not None for s in data.states] == [False, True]
    return data.modes


def test_a_pass_that_changes_only_the_modes_overlays_only_the_filters_modes() -> None:
    rng = np.random.default_rng(1)
    filtered = _result(rng)
    viterbi = _offline(filtered, modes=1 - filtered.modes)
    data = reduce_result(viterbi, _signals())
    assert isinstance(data.modes, ModeTimelines)
    assert data.modes.filtered is not None  # the modes differ: both drawn
    assert data.modes.filtered_probabilities is None
    assert all(state.filtered is None for state in data.states)


def test_a_curve_the_pass_changed_in_one_late_row_is_overlaid() -> None:
    rng = np.random.default_rng(2)
    filtered = _result(rng)
    means = filtered.state_means.copy()
    means[N - 3, 1] += 1e-9  # x2 differs in one row of the last chunk only
    modes = _chunked(_offline(filtered, state_means=means), [0, 200, 400, N])
    assert modes.filtered_probabilities is None
    probabilities = filtered.mode_probabilities[:, ::-1].copy()
    changed = _offline(filtered, state_means=means, mode_probabilities=probabilities)
    assert _chunked(changed, [0, 1, N]).filtered_probabilities is not None


def test_outputs_png_overlays_the_output_the_offline_estimate_explains(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the plots overlay the filter's and the offline estimates (issue 12); outputs.png drew
    # the filter's one-step-ahead prediction alone, where report.json scores both the filter's
    # and the smoothed explained outputs (smoothing.*.outputs)
    rng = np.random.default_rng(3)
    filtered = _result(rng)
    explained = filtered.output_predictions + 5.0
    smoothed = dataclasses.replace(
        filtered,
        post_processing=PostProcessing("kim-rts", "argmax", "test", filtered, explained=explained),
    )
    data = reduce_result(smoothed, _signals())
    assert data.explained_label == "smoothed"
    curve = data.outputs[0].explained
    assert curve is not None
    assert curve.values.max() == explained.max() and curve.values.min() == explained.min()
    plain = reduce_result(filtered, _signals())
    assert plain.outputs[0].explained is None and plain.explained_label == ""
    viterbi = _offline(filtered, modes=1 - filtered.modes)
    assert reduce_result(viterbi, _signals()).outputs[0].explained is None  # none carried
    drawn: list[Figure] = []
    save = plot_figures.save
    monkeypatch.setattr(plots, "save", lambda fig, path: drawn.append(fig) or save(fig, path))
    plots.plot_outputs(data, tmp_path / "smoothed.png")
    plots.plot_outputs(plain, tmp_path / "filtered.png")
    labels = [[line.get_label() for line in fig.axes[0].get_lines()] for fig in drawn]
    assert labels == [["measured", "predicted", "smoothed h(x̂)"], ["measured", "predicted"]]
    assert "h(x̂) of the smoothed estimate" in drawn[0].texts[0].get_text()
