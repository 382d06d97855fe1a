"""An estimator whose every sample fell back to its initial guess is refused, not scored.

``sliding-mode`` holds σ̂ where ``D(x, u)`` of eq. (30) is singular or not finite.  A log of
empty tanks 1 and 2 (``D`` rank-deficient), of all three empty (tank 3's cross-section
``w·sqrt(R² − (R − H3)²)`` is 0 there: ``0/0``, not finite), of negative levels or of levels
past the tanks' height (``sqrt`` of a negative number: ``D`` not finite) held it at every
sample: the run exited 0 with a mode accuracy and switches of a timeline that was the
observer's initial σ̂ = 0.
"""

from dataclasses import replace

import numpy as np
import pytest

from hybridlog.errors import ModelError
from hybridlog.estimators import prepare
from hybridlog.model.loader import load_model
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import simulate


@pytest.fixture(scope="module")
def valves():
    model = load_model("three_tank_valves")
    return model, simulate(model, steps=40, noise=False).signals(model)


def _with_levels(signals: AlignedSignals, levels: np.ndarray) -> AlignedSignals:
    return replace(signals, outputs=np.ascontiguousarray(levels))


@pytest.mark.parametrize(
    ("scale", "why"),
    [
        ((0.0, 0.0, 1.0), "not of full column rank"),
        (0.0, "not finite"),
        (-1.0, "not finite"),
        (1e12, "not finite"),
    ],
    ids=["empty-1-2", "empty", "negative", "past-the-top"],
)
def test_a_log_where_no_sample_reconstructs_the_mode_is_refused(valves, scale, why):
    model, signals = valves
    log = _with_levels(signals, signals.outputs * np.asarray(scale))
    with pytest.raises(ModelError) as caught:
        prepare(model, "sliding-mode").run(model, log)
    message = str(caught.value)
    assert message.startswith(
        "three_tank_valves: sliding-mode reconstructed no discrete state: D(x, u) of eq. (30) "
        f"is singular or not finite at all {signals.n_samples} samples ("
    )
    assert f"({why} at t = 0 s: H1 = " in message
    assert "\n" not in message and len(message) < 400


def test_a_log_where_some_samples_reconstruct_the_mode_is_kept(valves):
    model, signals = valves
    levels = signals.outputs.copy()
    levels[:20] = 0.0  # singular for half of the log: held there, noted, not refused
    # (the levels' jump from 0 leaves the rest unvouched by Lemma 1: max_unvouched = 1 keeps
    # this test to the singular samples)
    overrides = {"max_unvouched": 1.0}
    result = prepare(model, "sliding-mode", overrides).run(model, _with_levels(signals, levels))
    (note,) = [note for note in result.notes if note.startswith("D(x, u) was singular")]
    assert note.startswith("D(x, u) was singular on 20 samples")
