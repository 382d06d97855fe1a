"""Modes no log can tell apart (same equations and noise) are found and said in every report."""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.estimators import prepare
from hybridlog.model.cache import load_model
from hybridlog.model.loader import parse_model
from hybridlog.report import build_report, render_markdown
from hybridlog.simulate import simulate

HEAD = """
name = "twins"
time = "discrete"
dt = 0.1
states = ["x1"]
inputs = ["u"]
outputs = ["y"]
[parameters]
gain = 0.9
[noise]
process = 0.01
measurement = 0.01
[initial]
state = [0.0]
[simulation]
inputs = { u = "sin(t)" }
"""

MODES = {
    "a": 'f = ["0.9*x1 + u"]\nh = ["x1"]',
    "b": 'f = ["u + 0.9*x1"]\nh = ["x1"]',  # terms in another order
    "c": "A = [[0.9]]\nB = [[1.0]]\nC = [[1.0]]",  # the same, as matrices
    "d": 'f = ["gain*(x1 + u/gain)"]\nh = ["x1"]',  # the same, through a parameter
    "e": 'f = ["0.5*x1 + u"]\nh = ["x1"]',
    "sq": 'f = ["0.9*x1 + u*u"]\nh = ["sin(x1)"]',
    "sq2": 'f = ["u**2 + 0.9*x1"]\nh = ["sin(x1)"]',  # nonlinear twins
}


def model_text(modes: dict[str, str], tail: str = "") -> str:
    body = "".join(f"[modes.{m}]\n{spec}\n" for m, spec in modes.items())
    return HEAD + body + tail


def test_modes_with_the_same_functions_are_twins_however_written() -> None:
    model = parse_model(model_text(MODES))
    assert model.twin_modes == (("a", "b", "c", "d"), ("sq", "sq2"))


@pytest.mark.parametrize(
    ("extra", "why"),
    [
        ("measurement_noise = 0.02", "measurement noise"),
        ("process_noise = 0.02", "process noise"),
    ],
)
def test_twins_with_other_noise_are_told_apart(extra: str, why: str) -> None:
    modes = {"a": MODES["a"], "b": MODES["b"] + "\n" + extra}
    assert parse_model(model_text(modes)).twin_modes == (), why


def test_a_jump_map_of_one_twin_sets_them_apart() -> None:
    modes = {"a": MODES["a"], "b": MODES["b"], "e": MODES["e"]}
    tail = '[jumps."e->b"]\nx1 = "0"\n'
    assert parse_model(model_text(modes)).twin_modes == (("a", "b"),)
    assert parse_model(model_text(modes, tail)).twin_modes == ()


def test_a_warm_model_keeps_its_twins(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HYBRIDLOG_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "twins.toml"
    path.write_text(model_text(MODES), encoding="utf-8")
    cold, warm = load_model(path), load_model(path)
    assert warm.twin_modes == cold.twin_modes == (("a", "b", "c", "d"), ("sq", "sq2"))


def _report_notes(text: str) -> tuple[tuple[str, ...], str]:
    model = parse_model(text)
    log = simulate(model, schedule="a:20,b:20,e:20", jit=False)
    signals = log.signals(model)
    result = prepare(model, "imm").run(model, signals)
    report = build_report(
        result, signals, log="run.csv", model_name=model.name, dt=model.dt, model=model
    )
    return report.notes, render_markdown(report)


def test_every_report_names_the_twins_and_what_follows() -> None:
    modes = {"a": MODES["a"], "b": MODES["b"], "e": MODES["e"]}
    notes, markdown = _report_notes(model_text(modes))
    [note] = [n for n in notes if "no log can tell them apart" in n]
    assert "modes 'a' and 'b' have the same equations and noise" in note
    assert "tie, 'a', the first listed, is taken" in note and "mode accuracy" in note
    assert "[transitions] rows" not in note  # uniform prior, no Markov matrix: nothing differs
    assert "no log can tell them apart" in markdown.split("## Notes", 1)[1]
    # apart only by their Markov rows (legitimate for imm): said so
    matrix = "[[0.9, 0.05, 0.05], [0.2, 0.7, 0.1], [0.05, 0.05, 0.9]]"
    notes, _ = _report_notes(model_text(modes, f"[transitions]\nmatrix = {matrix}\n"))
    [note] = [n for n in notes if "no log can tell them apart" in n]
    assert "their [transitions] rows or initial probabilities differ" in note


def test_a_model_without_twins_gets_no_such_note() -> None:
    modes = {"a": MODES["a"], "b": MODES["e"], "e": MODES["sq"]}
    notes, _ = _report_notes(model_text(modes))
    assert not any("no log can tell them apart" in n for n in notes)


def test_a_large_group_of_twins_is_named_by_its_first_and_last() -> None:
    modes = {**{f"m{i}": MODES["a"] for i in range(12)}, "e": MODES["e"]}
    model = parse_model(model_text(modes))
    log = simulate(model, schedule="m0:5,e:5", jit=False)
    signals = log.signals(model)
    report = build_report(
        prepare(model, "imm").run(model, signals),
        signals,
        log="run.csv",
        model_name=model.name,
        dt=model.dt,
        model=model,
    )
    [note] = [n for n in report.notes if "no log can tell them apart" in n]
    assert note.startswith("NOTE: modes 'm0', 'm1', 'm2', 'm3', 'm4', 'm5', 'm6', 'm7', 'm8', ")
    assert "... and 'm11' (12 modes) have the same equations" in note


COMPONENTS = """
name = "valves"
dt = 1.0
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y1", "y2"]
[parameters]
k1 = 0.5
k2 = 0.5
k3 = 0.6
[noise]
process = [1e-4, 1e-4]
measurement = [1e-2, 1e-2]
[initial]
state = [0.0, 0.0]
[components.a]
unknown = 0.001
[components.a.modes.on]
equations = ["x1[k] = 0.5*x1[k-1] + u[k-1]", "y1 = x1"]
[components.a.modes.on_too]
equations = ["x1 = y1", "x1[k] = u[k-1] + k1*x1[k-1]"]  # reordered, through a parameter
[components.a.modes.other]
equations = ["x1[k] = k3*x1[k-1] + u[k-1]", "y1 = x1"]
[components.a.modes.noisier]
equations = ["x1[k] = 0.5*x1[k-1] + u[k-1]", "y1 = x1"]
measurement_noise = {y1 = 0.02}
[components.b]
unknown = 0.001
[components.b.modes.one]
equations = ["x2[k] = k1*x2[k-1]", "y2 = x2"]
[components.b.modes.two]
equations = ["x2[k] = k2*x2[k-1]", "y2 = x2"]  # another parameter of the same value
"""


def test_a_components_models_twin_modes_are_found_and_said() -> None:
    # Two modes of one component that no log can tell apart were said nowhere: the
    # component's mode accuracy counted the samples of the one not picked as errors.
    from hybridlog.report.model_notes import model_notes

    model = parse_model(COMPONENTS)
    assert model.component_twin_modes == (("a", ("on", "on_too")), ("b", ("one", "two")))
    notes = [n for n in model_notes(model) if "no log can tell them apart" in n]
    assert len(notes) == 2
    assert notes[0].startswith("NOTE: component 'a': modes 'on' and 'on_too' have the same")
    assert "detection delays of component 'a' count" in notes[0]
    apart = parse_model(COMPONENTS.replace("k2 = 0.5", "k2 = 0.4"))
    assert apart.component_twin_modes == (("a", ("on", "on_too")),)
