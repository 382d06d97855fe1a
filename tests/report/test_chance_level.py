"""A mode accuracy below chance (Cohen's kappa < 0) warns, in report.md and report.json.

``kmeans`` on the double cart (case 2) driven by sin(1.0 t) scored a mode accuracy of
28.3 % where modes drawn independently of the true ones, with the estimate's frequencies,
agree on 49.5 %: its clusters' labels (chosen by the observer's prediction fit) are the
reverse of the truth there.  The report said 28.3 %, exit 0, nothing else.
"""

from __future__ import annotations

import dataclasses
import re
from fractions import Fraction

import numpy as np

from hybridlog.report import build_report, render_markdown
from hybridlog.report.chance_level import below_chance
from hybridlog.report.markdown import WARNING_PREFIX

from .test_report_files import DT, make_run


def _warnings(modes: np.ndarray | None) -> list[str]:
    result, signals = make_run(400, seed=3)
    if modes is not None:
        result = dataclasses.replace(result, modes=modes)
    report = build_report(result, signals, log="run.csv", model_name="m", dt=DT)
    return [note for note in report.notes if "below chance" in note]


def test_an_accuracy_below_chance_warns_with_chance_and_kappa() -> None:
    _, signals = make_run(400, seed=3)
    assert signals.truth_modes is not None
    truth = signals.truth_modes
    wrong = (truth + 1) % 3  # never the true mode: accuracy 0, same frequencies shifted
    p_true = np.bincount(truth, minlength=3) / truth.size
    p_est = np.bincount(wrong, minlength=3) / truth.size
    chance = float(p_true @ p_est)
    (warning,) = _warnings(wrong)
    assert warning.startswith(f"{WARNING_PREFIX}mode accuracy 0.0 % is below chance")
    assert f"would agree on {100 * chance:.1f} % of these 400 samples" in warning
    assert f"(Cohen's kappa {-chance / (1 - chance):.2f})" in warning
    result, _ = make_run(400, seed=3)
    report = build_report(
        dataclasses.replace(result, modes=wrong), signals, log="run.csv", model_name="m", dt=DT
    )
    assert "## Warnings" in render_markdown(report)


def test_a_constant_answer_and_a_good_estimate_do_not_warn() -> None:
    _, signals = make_run(400, seed=3)
    assert signals.truth_modes is not None
    assert _warnings(np.zeros(400, dtype=np.int64)) == []  # at chance (kappa 0), not below
    assert _warnings(None) == []  # make_run's lagging estimate


def test_below_the_majority_share_is_not_below_chance() -> None:
    """98 % normal: catching every fault with false alarms scores 97 %, far above chance."""
    confusion = {"ok": {"ok": 950, "fault": 30}, "fault": {"ok": 0, "fault": 20}}
    assert below_chance(confusion) is None
    assert below_chance({"1": {"1": 95, "2": 5}}) is None  # one true mode: kappa 0
    reversed_labels = {"1": {"1": 10, "2": 90}, "2": {"1": 90, "2": 10}}
    assert "Cohen's kappa -0.80" in (below_chance(reversed_labels) or "")


def test_a_kappa_just_below_zero_is_not_printed_as_zero() -> None:
    # random labels: 50.2 % against a chance of 50.5 % read "(Cohen's kappa -0.00)", and
    # an accuracy a hair below chance "50.5 % is below chance ... would agree on 50.5 %"
    slightly = {"1": {"1": 251, "2": 249}, "2": {"1": 252, "2": 248}}
    said = below_chance(slightly) or ""
    assert "kappa -0.00)" not in said and "(Cohen's kappa -0.002)" in said, said
    assert "mode accuracy 49.9 % is below chance" in said and "agree on 50.0 %" in said, said
    hair = {"1": {"1": 5000, "2": 5000}, "2": {"1": 5001, "2": 4999}}
    said = below_chance(hair) or ""
    accuracy, chance = re.findall(r"(\d+\.\d+) %", said)
    assert accuracy != chance and float(accuracy) < float(chance), said


def test_below_chance_beyond_float64s_digits_is_said_exactly() -> None:
    # some 4e8 samples whose accuracy is below chance by 2 / N**2: the two floats are equal,
    # and looking for the digits that tell them apart raised StopIteration ("unexpected")
    k = 10**8
    confusion = {"a": {"a": k, "b": k + 1}, "b": {"a": k + 1, "b": k + 2}}
    said = below_chance(confusion)
    assert said is not None
    accuracy, chance = said.split(" % is below chance")[0], said.split("would agree on ")[1]
    accuracy = accuracy.removeprefix("mode accuracy ")
    chance = chance.split(" %")[0]
    assert accuracy != chance and float(accuracy) == float(chance)
    assert Fraction(accuracy) < Fraction(chance)
    assert "(Cohen's kappa -2e-17)" in said
