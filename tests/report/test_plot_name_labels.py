"""A panel's y label names its output, state or component in full, within the panel's height.

A symbol name has no length limit (a component's name up to 64 characters): drawn upright
on one line, a long one ran over the labels of the panels beside it and off the figure.
"""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path
from typing import Any

import pytest

from hybridlog.estimators.result import TimelineColumn
from hybridlog.report.plot_data import plain_text
from tests.support.figures import drawn_figures

from .test_plot_data import _run
from .test_report_files import make_run

LONG = "tank_level_measured_by_the_ultrasonic_sensor_mounted_on_the_lid_of_tank_one"
NAMES = (LONG, "水位_センサー_二_" + "x" * 30, "x_1")
COMPONENT = "flow_regulator_number_two_of_the_plant_growth_chamber_co2_line"


def _named_run() -> Any:
    result, signals = make_run(300)
    outputs, states = NAMES[:2], NAMES
    return (
        dataclasses.replace(result, output_names=outputs, state_names=states),
        dataclasses.replace(signals, output_names=outputs, state_names=states),
    )


def _components_run() -> Any:
    result, signals = _run(300, seed=3, components=True)
    columns = tuple(
        TimelineColumn(f"mode.{COMPONENT}", c.values, c.labels) if c.name == "mode.A" else c
        for c in result.timeline_columns
    )
    truth = {COMPONENT: signals.truth_components["A"]}
    return (
        dataclasses.replace(result, timeline_columns=columns),
        dataclasses.replace(signals, truth_components=truth),
    )


def _label_boxes(fig: Any) -> list[tuple[Any, Any, str]]:
    renderer = fig.canvas.get_renderer()
    return [
        (
            ax.get_window_extent(renderer),
            ax.yaxis.label.get_window_extent(renderer),
            ax.get_ylabel(),
        )
        for ax in fig.axes
        if ax.get_ylabel()
    ]


@pytest.mark.parametrize("kind", ["outputs and states", "components"])
def test_long_names_are_labelled_in_full_within_their_panels(
    kind: str, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from hybridlog.report import plots

    run = _named_run() if kind == "outputs and states" else _components_run()
    figures = drawn_figures(monkeypatch, lambda: plots.write_plots(tmp_path, *run))
    wanted = {"outputs.png": NAMES[:2], "states.png": NAMES}
    if kind == "components":
        wanted = {"modes.png": (COMPONENT, "B")}
    for name, names in wanted.items():
        boxes = _label_boxes(figures[name])
        shown = [text.replace("\n", "") for _, _, text in boxes]
        assert [plain_text(n) for n in names] == [s for s in shown if s not in ("joint",)], name
        for panel, label, text in boxes:
            assert label.height <= panel.height + 1.0, (name, text)
            assert label.x0 >= 0.0 and label.x1 <= panel.x0, (name, text)
        for (_, one, a), (_, other, b) in itertools.pairwise(boxes):
            assert not one.overlaps(other), (name, a, b)
