"""``sliding-mode``: a σ̂ held where eq. (30) gives no δ̃ is not vouched for.

Where ``D(x, u)`` is singular or not finite (an empty tank, a negative level) σ̂ is held from
the sample before.  Those samples were left out of ``max_unvouched``'s share and marked
``vouched = 1`` in the timeline: a log whose third tank read 0 on 7,401 of 8,001 samples
ran to exit 0, "σ̂ not vouched for on 36 samples (0.4 %)", with a mode accuracy of 18 %.
"""

from dataclasses import replace

import numpy as np
import pytest

from hybridlog.errors import DivergenceError
from hybridlog.estimators import prepare
from hybridlog.model.loader import load_model
from hybridlog.simulate import simulate


@pytest.fixture(scope="module")
def valves():
    model = load_model("three_tank_valves")
    return model, simulate(model, steps=300, noise=False).signals(model)


def test_held_samples_count_against_max_unvouched(valves):
    model, signals = valves
    levels = signals.outputs.copy()
    levels[100:, 2] = 0.0  # tank 3 empty from sample 100: D's third column is 0
    log = replace(signals, outputs=np.ascontiguousarray(levels))
    with pytest.raises(DivergenceError) as caught:
        prepare(model, "sliding-mode").run(model, log)
    message = str(caught.value)
    assert message.startswith("three_tank_valves: sliding-mode cannot vouch for σ̂ on ")
    assert "singular or not finite at the measured state (σ̂ held) on 201 samples," in message
    assert "\n" not in message and len(message) < 400


def test_held_samples_are_not_vouched_in_the_timeline(valves):
    model, signals = valves
    levels = signals.outputs.copy()
    levels[200:210, 2] = 0.0
    log = replace(signals, outputs=np.ascontiguousarray(levels))
    result = prepare(model, "sliding-mode").run(model, log)
    columns = {c.name: c.values for c in result.timeline_columns}
    held = np.isnan(columns["delta_tilde.U3"])
    assert held.sum() == 10 and np.all(held[200:210])
    assert np.all(columns["vouched"][held] == 0.0)
    assert any("σ̂ held and not vouched for" in note for note in result.notes)
