"""modes.png of odd but valid models: long mode ids, many modes, ids the fonts cannot draw."""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.estimators.result import EstimationResult, PostProcessing
from hybridlog.report.plot_data import Components, plain_text
from hybridlog.report.plot_reducer import reduce_result
from hybridlog.signals import AlignedSignals
from tests.support.figures import drawn_figures

from .test_plot_data import _run
from .test_report_files import make_run

#: Two model-file ids of 60 characters that differ only in their last one.
LONG_IDS = ("valve_" + "a" * 54, "valve_" + "a" * 53 + "b", "i")


def _with_modes(
    ids: tuple[str, ...], *, smoothed: bool = False
) -> tuple[EstimationResult, AlignedSignals]:
    """``make_run``'s run with ``ids`` as its modes (the first three estimated and true)."""
    result, signals = make_run(300)
    rng = np.random.default_rng(3)
    probabilities = rng.random((300, len(ids))) + 2.0 * np.eye(len(ids))[result.modes]
    probabilities /= probabilities.sum(axis=1, keepdims=True)
    result = dataclasses.replace(result, mode_ids=ids, mode_probabilities=probabilities)
    if smoothed:  # the filter's own probabilities differ, as a smoother's input does
        filtered = dataclasses.replace(result, mode_probabilities=probabilities[::-1].copy())
        post = PostProcessing("kim-rts", "argmax", "test", filtered)
        result = dataclasses.replace(result, post_processing=post)
    return result, signals


def _drawn_modes(monkeypatch: pytest.MonkeyPatch, draw: Any) -> Any:
    """The modes.png figure as saved by ``draw()`` (drawn, so that text has its place)."""
    return drawn_figures(monkeypatch, draw)["modes.png"]


def _texts(fig: Any) -> list[Any]:
    texts = [t for ax in fig.axes for t in (*ax.get_yticklabels(), ax.yaxis.label)]
    for legend in [*fig.legends, *(ax.get_legend() for ax in fig.axes)]:
        if legend is not None:
            texts.extend([*legend.get_texts(), legend.get_title()])
    return [t for t in texts if t.get_text() and t.get_visible()]


def _assert_inside(fig: Any) -> None:
    renderer = fig.canvas.get_renderer()
    for text in [*_texts(fig), fig._suptitle]:
        box = text.get_window_extent(renderer)
        assert box.x0 >= 0.0 and box.x1 <= fig.bbox.width, text.get_text()
        assert box.y0 >= 0.0 and box.y1 <= fig.bbox.height, text.get_text()


def _legend_below_panels(fig: Any) -> list[str]:
    """The texts of the figure's legend below its panels (asserted to be below them)."""
    renderer = fig.canvas.get_renderer()
    (legend,) = fig.legends
    lowest = min(ax.get_tightbbox(renderer).y0 for ax in fig.axes)
    assert legend.get_window_extent(renderer).y1 <= lowest
    return [t.get_text() for t in legend.get_texts()]


@pytest.mark.parametrize("smoothed", [False, True])
def test_long_mode_ids_are_keys_listed_in_full_below_the_panels(
    smoothed: bool, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """60-character ids were cut off at the figure's left edge (the margin stops at half the
    width), and so was the probabilities' legend: two ids that differ at their end could not
    be told apart."""
    from hybridlog.report import plots

    result, signals = _with_modes(LONG_IDS, smoothed=smoothed)
    fig = _drawn_modes(monkeypatch, lambda: plots.write_plots(tmp_path, result, signals))
    mode_axes = fig.axes[0]
    assert [t.get_text() for t in mode_axes.get_yticklabels()] == ["[1]", "[2]", "[3]"]
    entries = _legend_below_panels(fig)
    assert entries[:3] == [f"[{k + 1}]: {m}" for k, m in enumerate(LONG_IDS)]
    assert entries[3:] == (["filtered (dashed, same colours)"] if smoothed else [])
    _assert_inside(fig)


def test_short_mode_ids_label_their_rows_with_the_legend_below(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The probabilities' legend of up to 6 entries sat in the panel's upper right corner,
    over the most probable mode's curve near 1."""
    from hybridlog.report import plots

    result, signals = _with_modes(("open", "closed", "m" * 20), smoothed=True)
    fig = _drawn_modes(monkeypatch, lambda: plots.write_plots(tmp_path, result, signals))
    assert [t.get_text() for t in fig.axes[0].get_yticklabels()] == ["open", "closed", "m" * 20]
    assert fig.axes[1].get_legend() is None
    assert _legend_below_panels(fig) == [
        "p(open)", "p(closed)", f"p({'m' * 20})", "filtered (dashed, same colours)"
    ]  # fmt: skip
    _assert_inside(fig)


def test_twelve_modes_get_twelve_curves_apart_and_a_legend_off_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The 11th mode's probability took the 1st's colour (a cycle of 10), and the legend of
    20 entries covered the top of the panel, where the most probable mode's curve runs."""
    from matplotlib.colors import to_hex

    from hybridlog.report import plots

    ids = tuple(f"m{j}" for j in range(12))
    result, signals = _with_modes(ids)
    fig = _drawn_modes(monkeypatch, lambda: plots.write_plots(tmp_path, result, signals))
    lines = [line for line in fig.axes[1].get_lines() if line.get_label().startswith("p(")]
    looks = {(to_hex(line.get_color()), line.get_linestyle()) for line in lines}
    assert len(lines) == 12 and len(looks) == 12
    assert _legend_below_panels(fig) == [f"p({m})" for m in ids]
    _assert_inside(fig)


def test_a_components_figure_keys_every_panel_when_one_is_too_wide(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from hybridlog.report import mode_plots

    result, signals = _run(500, seed=2, components=True)
    data = reduce_result(result, signals)
    assert isinstance(data.modes, Components)
    column = data.modes.columns[0]
    labels = tuple(f"{label}_{'x' * 56}"[:64] for label in column.labels)
    data = dataclasses.replace(
        data,
        modes=data.modes._replace(columns=(column._replace(labels=labels),)),
    )
    fig = _drawn_modes(monkeypatch, lambda: mode_plots.plot_modes(data, tmp_path / "modes.png"))
    shown = [t.get_text() for ax in fig.axes for t in ax.get_yticklabels()]
    assert all(s.startswith("[") for s in shown), shown
    entries = _legend_below_panels(fig)
    assert [e.split(": ", 1)[1] for e in entries[: len(labels)]] == list(labels)
    _assert_inside(fig)


def test_ids_the_fonts_cannot_draw_are_escaped_not_boxes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``閉じた`` and ``開いた`` were drawn as the same three empty boxes (and matplotlib's
    'Glyph missing' warning, an error under this suite's filterwarnings)."""
    from hybridlog.report import plots

    assert plain_text("閉じた") == r"\u9589\u3058\u305f"
    assert plain_text("開いた") == r"\u958b\u3044\u305f"
    assert plain_text("ouvert-à-moitié θ") == "ouvert-à-moitié θ"
    assert plain_text("🚰$") == r"\U0001f6b0\$"
    result, signals = _with_modes(("閉じた", "開いた", "ouvert-à-moitié"))
    fig = _drawn_modes(monkeypatch, lambda: plots.write_plots(tmp_path, result, signals))
    shown = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    assert shown == [r"\u9589\u3058\u305f", r"\u958b\u3044\u305f", "ouvert-à-moitié"]


@pytest.mark.parametrize("n_modes", [25, 120])
def test_many_modes_get_rows_whose_labels_stand_apart(
    n_modes: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The mode panel was 2.4 in high for any number of modes: from 17 on, the rows' labels
    ran into one another and no row could be told from its neighbours.  The panel grows with
    the modes (up to a cap, beyond which the labels' font shrinks to their rows)."""
    from hybridlog.report import plots

    ids = tuple(f"mode {j}" for j in range(n_modes))
    result, signals = _with_modes(ids)
    fig = _drawn_modes(monkeypatch, lambda: plots.write_plots(tmp_path, result, signals))
    renderer = fig.canvas.get_renderer()
    labels = fig.axes[0].get_yticklabels()
    assert [t.get_text() for t in labels] == list(ids)
    boxes = sorted((t.get_window_extent(renderer) for t in labels), key=lambda b: b.y0)
    for below, above in itertools.pairwise(boxes):
        assert below.y1 <= above.y0, (below, above)
    _assert_inside(fig)
