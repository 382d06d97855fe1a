"""``hybridlog cluster`` warns when its decision rule scores below the majority share.

On the double cart (case 2) driven by sin(1.0 t), above its first resonance, the true mode
is '2' 63.5 % of the time; ``cluster --compare-kmeans`` printed the decision rule's mode
accuracy, chiu 0.4246 and kmeans 0.2827, and wrote the centres without a word
(``analyze`` warns of the same in its report, :mod:`hybridlog.report.chance_level`).
"""

from __future__ import annotations

from pathlib import Path

from hybridlog.jobs.cluster import discover_modes
from hybridlog.jobs.simulate import simulate_log
from hybridlog.model.builtins import builtin_text
from tests.support.paths import SAMPLE_LOGS


def test_a_decision_rule_below_the_majority_share_warns_per_algorithm(tmp_path: Path) -> None:
    model = tmp_path / "fast.toml"
    text = builtin_text("double_cart_case2")
    model.write_text(text.replace('u = "sin(0.3*t)"', 'u = "sin(1.0*t + 0.7)"'))
    log = tmp_path / "fast.csv"
    simulate_log(model, log, steps=1000, seed=1)
    outcome = discover_modes(log, model, out=tmp_path / "c.json", compare_kmeans=True)
    warned = [a for a in outcome.alerts if "most frequent true mode '2'" in a]
    assert [a.split(":")[1].strip() for a in warned] == ["chiu", "kmeans"]
    assert "the decision rule's mode accuracy 28.3 % is below the 63.5 %" in warned[1]


def test_the_sample_log_does_not_warn(tmp_path: Path) -> None:
    outcome = discover_modes(
        SAMPLE_LOGS / "double_cart_case2.csv",
        "double_cart_case2",
        out=tmp_path / "c.json",
        compare_kmeans=True,
    )
    assert not [a for a in outcome.alerts if "most frequent" in a]
