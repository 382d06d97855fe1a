"""What the plots of one run draw, reduced from the result: :class:`PlotData` and its parts.

The figures (:mod:`hybridlog.report.plots`) are drawn from a :class:`PlotData`: a small,
picklable value of NumPy arrays, strings and numbers, whose size does not grow with the run
beyond one reduction per pixel column.  It is made with NumPy only (no matplotlib), so
the process that analyses a long run can reduce it and leave the drawing to another process
that receives only the reduced data (:mod:`hybridlog.report.plot_reducer`, a chunk of the
result's rows at a time).  Its curves are reduced per pixel column of the panels
(:mod:`hybridlog.report.pixel_bins`) to their first, minimum, maximum and last sample and
its ±2σ bands to their edges (:mod:`hybridlog.report.curve_envelopes`), its mode timelines
to the pixel columns each mode occupies (:mod:`hybridlog.report.timeline_bars`).  At most
:data:`MAX_PANELS` outputs/states are drawn, so only those are reduced.  User text enters
a figure through :func:`plain_text`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

from hybridlog.signals import FloatArray

if TYPE_CHECKING:
    from hybridlog.report.curve_envelopes import Envelope, SigmaBand
    from hybridlog.report.timeline_bars import Bars

__all__ = [
    "COMPONENT_PREFIX",
    "MAX_PANELS",
    "ComponentTimeline",
    "Components",
    "ModeTimelines",
    "OutputCurves",
    "PlotData",
    "StateCurves",
    "plain_text",
]


MAX_PANELS = 16
"""Outputs and states drawn (and reduced) at most, one panel each."""
COMPONENT_PREFIX = "mode."
"""Timeline columns ``mode.<component>`` hold a ``[components]`` model's per-component modes."""


def plain_text(text: str) -> str:
    r"""``text`` (a mode id, a name from a model, a log path) as matplotlib shows it, as it is.

    matplotlib reads a text with an even number of unescaped ``$`` as mathtext: the mode
    ``$x_1$`` was drawn as x₁ (beside a mode ``x_1``, two identical tick labels), and one
    mathtext cannot parse (``$\frac$``, ``$\undefined{$``) raised while the figure was
    saved, which lost the whole report.  Every ``$`` written ``\$`` is a text without math,
    shown with the dollars as they were (matplotlib unescapes ``\$`` there and nothing else).
    Every label, tick label and title of user text in a figure goes through this.

    A character the figures' fonts cannot draw (``閉``, ``🚰``: matplotlib's fonts have no
    CJK or emoji) is written as its escape, ``\u9589``: drawn, it was an empty box, and two
    ids of as many such characters looked the same (:mod:`hybridlog.report.glyphs`, which
    loads matplotlib's fonts, is imported only for text that is not ASCII or holds ``\u`` or
    ``\U``); where it writes an escape or the text holds ``\u`` or ``\U``, its backslashes are
    written twice, so that no text is drawn as another's escape (``\u9589`` as ``\\u9589``).
    """
    if not text.isascii() or "\\u" in text or "\\U" in text:
        from hybridlog.report.glyphs import escape_undrawable

        text = escape_undrawable(text)
    return text.replace("$", r"\$")


class OutputCurves(NamedTuple):
    """One panel of ``outputs.png``: the measured output and its one-step-ahead prediction.

    ``explained``: of a result with ``post_processing``, the output its offline estimate
    explains, ``h_q̂(k)(x̂(k|N), u(k))`` (:mod:`hybridlog.estimators.explained`: an
    a-posteriori fit, not a prediction); ``None`` otherwise, or where the result does not
    carry it.
    """

    name: str
    measured: Envelope
    predicted: Envelope
    explained: Envelope | None = None


class StateCurves(NamedTuple):
    """One panel of ``states.png``: the estimate, its ±2σ band, the truth and the filter's.

    ``band`` is ``None`` where no variance is defined, ``truth`` where the log has no finite
    true value of the state, ``filtered`` for a result without ``post_processing`` or whose
    pass left the filter's estimate of the state as it was (the Viterbi path alone).
    """

    name: str
    band: SigmaBand | None
    truth: Envelope | None
    estimate: Envelope
    filtered: Envelope | None


class ModeTimelines(NamedTuple):
    """``modes.png``: the mode timelines as bars, and the mode probabilities.

    Attributes
    ----------
    mode_ids:
        The model's modes, one row each.
    label:
        The legend of the estimated mode: ``estimated``, ``smoothed``, ``viterbi`` or
        ``kbest``.
    estimated, truth, filtered:
        The bars of the estimated mode, of the true one (``None`` when unknown), and of the
        causal filter's own (``None`` without ``post_processing``).
    probabilities, filtered_probabilities:
        One curve per mode; the filter's are ``None`` without ``post_processing`` or where
        the pass left the filter's probabilities as they were (``viterbi``, ``kbest``
        without ``smooth``).
    """

    mode_ids: tuple[str, ...]
    label: str
    estimated: Bars
    truth: Bars | None
    filtered: Bars | None
    probabilities: tuple[Envelope, ...]
    filtered_probabilities: tuple[Envelope, ...] | None


class ComponentTimeline(NamedTuple):
    """The bars of one component's modes (its ``mode.<component>`` column), one row per label.

    ``labels`` are the column's, then those of the log's true modes of the component that
    the column does not have; ``truth`` the bars of the true mode (``None`` when the log has
    none), ``filtered`` those of the causal filter's own column (``None`` without
    ``post_processing``).
    """

    name: str
    labels: tuple[str, ...]
    bars: Bars
    truth: Bars | None = None
    filtered: Bars | None = None


class Components(NamedTuple):
    """``modes.png`` of a ``[components]`` result: a timeline per component, and the joint one.

    ``joint_ids`` are the joint assignments the estimate or the causal filter visited (in
    the model's order), ``joint`` the estimate's bars of them, ``joint_filtered`` the
    filter's (``None`` without ``post_processing``); ``label`` the estimate's legend, as
    :attr:`ModeTimelines.label`.
    """

    columns: tuple[ComponentTimeline, ...]
    joint_ids: tuple[str, ...]
    joint: Bars
    joint_filtered: Bars | None = None
    label: str = "estimated"


@dataclass(frozen=True)
class PlotData:
    """Everything the three figures of a run draw, reduced (see module); picklable.

    Attributes
    ----------
    n_samples:
        Samples of the run.
    time_origin:
        The time every time below counts from (:func:`time_origin`; the x label says it,
        :func:`time_label`).
    span:
        ``(t_0, t_end)``: the panels' x range; ``None`` for no samples.
    edges:
        Time of each pixel column's first sample, then the run's end: the bars' edges.
    output_names, state_names:
        All outputs and states (the figure's title says how many of them are drawn).
    outputs, states:
        One panel each, for at most :data:`MAX_PANELS` of them.
    state_label:
        The legend of the state estimate: ``estimate`` or ``smoothed``.
    modes:
        The mode timelines, a ``[components]`` result's per-component ones, or ``None``
        for no samples.
    explained_label:
        Which estimate the outputs' ``explained`` curves are of: ``smoothed``, ``viterbi``
        or ``kbest`` (``""`` without them).
    """

    n_samples: int
    time_origin: float
    span: tuple[float, float] | None
    edges: FloatArray
    output_names: tuple[str, ...]
    outputs: tuple[OutputCurves, ...]
    state_names: tuple[str, ...]
    state_label: str
    states: tuple[StateCurves, ...]
    modes: ModeTimelines | Components | None
    explained_label: str = ""
