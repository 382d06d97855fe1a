"""Plots of runs whose names a hostile user chose: text is drawn as it is, never as mathtext."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.estimators.result import EstimationResult
from hybridlog.report.plot_data import plain_text
from hybridlog.signals import AlignedSignals
from tests.support.figures import patch_save

from .test_report_files import make_run

#: Mode ids (model files allow any printable text) that matplotlib took for mathtext: drawn
#: as other text, or refused by its parser while the figure was saved.
MATHTEXT_IDS = [
    ("$x_1$", "a_b^c", "plain"),
    (r"$\frac$", r"$\undefinedcmd{$", "c"),
    ("$", "$$", r"\$x$"),
    ("$^$", "${}$", r"a\$b$c$"),
]


@given(st.text(alphabet=st.sampled_from("$\\^_{}ab x1"), max_size=12) | st.text(max_size=12))
@settings(max_examples=300, deadline=None)
def test_plain_text_is_shown_as_it_is(text: str) -> None:
    """As written, but for characters no font of the figures holds, written as escapes."""
    from matplotlib.text import Text

    from hybridlog.report.glyphs import drawable, escape_undrawable

    label = Text(text=plain_text(text))
    shown, math = label._preprocess_math(label.get_text())
    assert (shown, math) == (escape_undrawable(text), False)
    assert all(c.isascii() or drawable(c) for c in shown)


@given(st.lists(st.text(alphabet=st.sampled_from("閉🚰\\uU9589$a"), max_size=8), unique=True))
@settings(max_examples=300, deadline=None)
def test_different_texts_are_never_shown_alike(texts: list[str]) -> None:
    r"""The mode ids ``閉`` and ``\u9589`` (six ASCII characters) were both drawn ``\u9589``."""
    from matplotlib.text import Text

    shown = {Text(text=plain_text(text))._preprocess_math(plain_text(text))[0] for text in texts}
    assert len(shown) == len(texts)
    assert plain_text("閉") == r"\u9589" and plain_text(r"\u9589") == r"\\u9589"
    assert plain_text(r"a\b") == r"a\b"  # a backslash that reads as no escape stays single


def _run_with_modes(ids: tuple[str, str, str]) -> tuple[EstimationResult, AlignedSignals]:
    result, signals = make_run(300)
    return dataclasses.replace(result, mode_ids=ids), signals


@pytest.mark.parametrize("ids", MATHTEXT_IDS, ids=lambda ids: "|".join(ids))
def test_mode_ids_with_dollars_are_drawn_as_written(
    ids: tuple[str, str, str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from matplotlib.figure import Figure

    from hybridlog.report import plot_figures, plots

    drawn: list[str] = []
    save = plot_figures.save

    def texts_then_save(fig: Figure, path: Path) -> Path:
        drawn.extend(t.get_text() for ax in fig.axes for t in ax.get_yticklabels())
        legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes)]
        drawn.extend(t.get_text() for legend in legends if legend for t in legend.get_texts())
        return save(fig, path)

    patch_save(monkeypatch, texts_then_save)
    result, signals = _run_with_modes(ids)
    written = plots.write_plots(tmp_path, result, signals)
    assert [p.name for p in written] == ["outputs.png", "modes.png", "states.png"]
    for mode in ids:
        assert plain_text(mode) in drawn
        assert f"p({plain_text(mode)})" in drawn


def test_a_batch_summary_of_a_model_named_in_mathtext_is_drawn(tmp_path: Path) -> None:
    from hybridlog.report.summary_plot import summary_figure, write_summary_plot
    from hybridlog.report.summary_rows import BatchRow

    rows = [
        BatchRow(
            log=f"run_${k}$.csv", folder=rf"run_$\frac{k}$", status="failed", report=None, error="x"
        )
        for k in range(3)
    ]
    title = r"$\undefinedcmd{$ · imm"
    write_summary_plot(tmp_path / "summary.png", title, rows)
    fig = summary_figure(title, rows)
    assert fig.get_suptitle().startswith(plain_text(title))
    shown = [t.get_text() for t in fig.axes[-1].get_xticklabels()]
    assert shown == [plain_text(rf"run_$\frac{k}$") for k in range(3)]
    assert np.all([not t._preprocess_math(t.get_text())[1] for t in fig.axes[-1].get_xticklabels()])


@pytest.mark.parametrize("width", [1, 16, 32])
def test_every_mode_id_is_inside_the_modes_figure(
    width: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Long mode ids were cut off at the fixed margin (up to half the figure now fits)."""
    from matplotlib.figure import Figure

    from hybridlog.report import plot_figures, plots

    lefts: list[float] = []
    save = plot_figures.save

    def measured_then_save(fig: Figure, path: Path) -> Path:
        if path.name == "modes.png":
            fig.canvas.draw()  # labels placed as in the PNG
            renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
            for ax in fig.axes:
                labels = [*ax.get_yticklabels(), ax.yaxis.label]
                lefts.extend(
                    t.get_window_extent(renderer).x0
                    for t in labels
                    if t.get_text() and t.get_visible()
                )
        return save(fig, path)

    patch_save(monkeypatch, measured_then_save)
    ids = ("q" * width, "m" * max(width - 1, 1) + "2", "i")
    plots.write_plots(tmp_path, *_run_with_modes(ids))
    assert len(lefts) >= 5 and min(lefts) >= 0.0


def _extreme(case: str) -> tuple[EstimationResult, AlignedSignals]:
    result, signals = make_run(300)
    means, variances = result.state_means.copy(), result.state_variances.copy()
    predicted, truth = result.output_predictions.copy(), signals.truth_states.copy()  # type: ignore[union-attr]
    sign = np.where(np.arange(300) % 2, 1.0, -1.0)
    if case == "diverged":  # finite, but the range of a panel overflows float64
        means[:, 0] = 1.7e308 * sign
        variances[:, 0] = 1.7e308
        predicted[1:, 0] = 1e308 * sign[1:]
    elif case == "subnormal":
        means[:, 0] = 1e-310 * np.arange(300)
        variances[:, 0] = 1e-320
        predicted[1:, 0] = 5e-324 * sign[1:]
    elif case == "constant":
        means[:, 0] = truth[:, 0] = 3.0
        variances[:, 0] = 0.0
        predicted[1:, 0] = 7.0
    else:  # far apart: 1e300 against 1e-300
        means[:, 0] = 1e300
        truth[:, 0] = 1e-300
    return (
        dataclasses.replace(
            result, state_means=means, state_variances=variances, output_predictions=predicted
        ),
        dataclasses.replace(signals, truth_states=truth),
    )


@pytest.mark.parametrize(
    ("case", "unit"),
    [("diverged", " (×1e308)"), ("subnormal", ""), ("constant", ""), ("apart", "")],
)
def test_extreme_values_are_drawn_in_a_unit_that_keeps_the_axes_finite(
    case: str, unit: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Values near ±1.8e308 overflowed matplotlib's autoscaling (a RuntimeWarning: no report)."""
    from matplotlib.figure import Figure

    from hybridlog.report import plot_figures, plots

    labels: dict[str, list[str]] = {}
    save = plot_figures.save

    def labelled_then_save(fig: Figure, path: Path) -> Path:
        labels[path.name] = [ax.get_ylabel() for ax in fig.axes]
        return save(fig, path)

    patch_save(monkeypatch, labelled_then_save)
    plots.write_plots(tmp_path, *_extreme(case))
    assert labels["states.png"][0] == f"x1{unit}"
    assert labels["outputs.png"][0] == f"y1{unit}"
    assert labels["states.png"][1:] == ["x2", "x3"]


def test_the_cluster_plot_draws_mode_ids_as_written(tmp_path: Path) -> None:
    """``hybridlog cluster``'s picture (jobs/cluster_plot.py) quotes the modes too."""
    from hybridlog.jobs.cluster_plot import plot_clusters

    rng = np.random.default_rng(1)
    phi = rng.normal(size=(60, 2))
    modes = (r"$\undefinedcmd{$", "$x_1$")
    written = plot_clusters(
        tmp_path / "clusters.png",
        time=np.arange(60.0),
        phi=phi,
        names=("y(k)", "y(k-1)"),
        clusters=np.arange(60) % 2,
        centers=phi[:2],
        cluster_modes=modes,
        decision_values=np.array([0.5, 1.5]),
        mode_ids=modes,
        truth=[modes[k % 2] for k in range(60)],
    )
    assert written.stat().st_size > 0


@pytest.mark.parametrize("name", ["a\nb\rc", "Wide_model_" * 30, "W" * 200 + "\n"])
def test_a_batch_summary_title_is_two_lines_within_the_figure(name: str) -> None:
    """A model name with a line break made the title three lines, the last over the first
    panel; one of 300 characters ran off both sides of the figure, the estimator's name with
    it.  The title is its model · estimator line and the counts line, inside the figure."""
    from hybridlog.report.summary_plot import summary_figure
    from hybridlog.report.summary_rows import BatchRow

    rows = [BatchRow(log="a.csv", folder="a.csv", status="failed", report=None, error="x")]
    fig = summary_figure(f"{name} · imm", rows)
    title = fig._suptitle
    assert title is not None
    lines = title.get_text().split("\n")
    assert len(lines) == 2
    assert lines[0].endswith(" · imm")
    renderer = fig.canvas.get_renderer()
    box = title.get_window_extent(renderer)
    assert box.x0 >= 0 and box.x1 <= fig.bbox.width
    assert box.y0 >= max(ax.get_window_extent(renderer).y1 for ax in fig.axes)
