"""``hybridlog cluster`` warns when its decision rule's mode accuracy is below chance.

On the double cart (case 2) driven by sin(1.0 t), above its first resonance,
``cluster --compare-kmeans`` printed the decision rule's mode accuracy, chiu 0.4246 and
kmeans 0.2827, where modes drawn independently of the true ones with the same frequencies
agree on 54 % and 49 % of the samples, and wrote the centres without a word (``analyze``
warns of the same in its report, :mod:`hybridlog.report.chance_level`).
"""

from __future__ import annotations

from pathlib import Path

from hybridlog.jobs.cluster import discover_modes
from hybridlog.jobs.simulate import simulate_log
from hybridlog.model.builtins import builtin_text
from tests.support.paths import SAMPLE_LOGS


def test_a_decision_rule_below_chance_warns_per_algorithm(tmp_path: Path) -> None:
    model = tmp_path / "fast.toml"
    text = builtin_text("double_cart_case2")
    model.write_text(text.replace('u = "sin(0.3*t)"', 'u = "sin(1.0*t + 0.7)"'))
    log = tmp_path / "fast.csv"
    simulate_log(model, log, steps=1000, seed=1)
    outcome = discover_modes(log, model, out=tmp_path / "c.json", compare_kmeans=True)
    warned = [a for a in outcome.alerts if "below chance" in a]
    assert [a.split(":")[1].strip() for a in warned] == ["chiu", "kmeans"]
    assert warned[1].startswith(
        "warning: kmeans: the decision rule's mode accuracy 28.3 % is below chance: estimated "
        "modes drawn independently of the true ones, with the same frequencies, would agree "
        "on 49.5 % of these 1,001 samples (Cohen's kappa -0.42)"
    )


def test_the_sample_log_does_not_warn(tmp_path: Path) -> None:
    outcome = discover_modes(
        SAMPLE_LOGS / "double_cart_case2.csv",
        "double_cart_case2",
        out=tmp_path / "c.json",
        compare_kmeans=True,
    )
    assert not [a for a in outcome.alerts if "chance" in a]
