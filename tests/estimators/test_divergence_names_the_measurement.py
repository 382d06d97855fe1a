"""A diverged ``switching-observer`` run names the measurement that drove it there.

One sample of 1e6 in the clutch's engine speed (about 150 rad/s) made the observer's next
estimate not finite; the refusal blamed "Q singular, a jump map or the gain ... too large
for the integration step", all of which were fine, and showed nothing of the log: a user
searched the model for a fault of the log.  The refusal now also gives the output measured
on the interval before and the prediction it corrected, and the estimate there.
"""

import re
from dataclasses import replace

import numpy as np
import pytest

from hybridlog.errors import ModelError
from hybridlog.estimators import prepare
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import load_model
from hybridlog.simulate import simulate

SPIKE = 60


@pytest.fixture(scope="module")
def clutch():
    model = load_model("ice_clutch")
    return model, simulate(model, steps=SPIKE + 20, noise=False).signals(model)


def test_an_outlier_that_breaks_the_observer_is_shown_beside_its_prediction(clutch):
    model, signals = clutch
    outputs = signals.outputs.copy()
    outputs[SPIKE, 0] = 1e6
    with pytest.raises(ModelError) as caught:
        prepare(model, "switching-observer").run(model, replace(signals, outputs=outputs))
    message = str(caught.value)
    assert message.startswith(
        f"ice_clutch: switching-observer diverged at t = 0.{SPIKE + 1} s (sample {SPIKE + 1}): "
    )
    predicted = re.search(
        r"; the interval before corrected with y = 1e\+06 measured against "
        r"(\S+) predicted at the estimate m = \S+, omega = \S+, T = \S+$",
        message,
    )
    assert predicted is not None, message
    assert abs(float(predicted.group(1))) < 1e3
    assert "\n" not in message and len(message) < 400


def test_a_broken_first_step_has_no_prediction_to_show(clutch):
    model, signals = clutch
    with pytest.raises(ModelError) as caught:
        prepare(model, "switching-observer").run(
            model, replace(signals, outputs=np.ascontiguousarray(signals.outputs * 1e12))
        )
    message = str(caught.value)
    assert "(sample 1): " in message
    assert "; the interval before corrected with y = 1.4" in message
    assert " measured at the estimate m = " in message and "predicted" not in message


def engagement_refused(tmp_path, omega):
    """The refusal of the clutch's observer whose engagement map is ``omega = "<omega>"``, on
    a log of the built-in (whose map keeps omega's sign and size), and that log's signals."""
    text = builtin_text("ice_clutch")
    edited = text.replace('omega = "JE/(JE + JL)*omega"', f'omega = "{omega}"')
    assert edited != text
    path = tmp_path / "clutch.toml"
    path.write_text(edited)
    plant = load_model("ice_clutch")
    signals = simulate(plant, steps=700, noise=False).signals(plant)
    model = load_model(str(path))
    with pytest.raises(ModelError) as caught:
        prepare(model, "switching-observer").run(model, signals)
    return str(caught.value), signals


def test_a_jump_map_the_log_does_not_bear_out_is_named(tmp_path):
    """``omega = "-omega"`` at the clutch's engagement: the estimate diverged 4 samples later
    and the refusal named the gain alone, never the map that threw it off the log."""
    message, signals = engagement_refused(tmp_path, "-omega")
    named = re.search(
        r'; the jump map jumps\."0->1", applied just after t = (\S+) s, (\d+) samples? '
        r"before, left the estimate predicting y = (\S+) against (\S+) measured at t = (\S+) "
        r"s$",
        message,
    )
    assert named is not None, message
    assert float(named.group(3)) < 0 < float(named.group(4))
    # the mode of row k + 1 runs the interval into it, its map applied at t_k^+ (as simulate)
    switch = int(np.flatnonzero(np.diff(signals.truth_modes))[-1]) + 1
    assert float(named.group(1)) == pytest.approx(signals.time[switch - 1])
    assert float(named.group(5)) == pytest.approx(signals.time[switch])


def test_a_divergence_in_the_interval_a_switch_opened_says_it_ran_open_loop(tmp_path):
    """The interval after a switch runs from the jumped estimate without correction (its
    only measurement was taken before the jump): not "corrected with y = ...", which it
    was not, but the switch and the map applied."""
    message, signals = engagement_refused(tmp_path, "1e200*omega")
    switch = int(np.flatnonzero(np.diff(signals.truth_modes))[0]) + 1
    assert f"(sample {switch}): " in message
    assert re.search(
        r"; the interval before ran without correction \(the switch to mode '1' just after "
        r"t = \S+ s\) from the estimate m = \S+, omega = \S+, T = \S+, then "
        r'jumps\."0->1"$',
        message,
    ), message
    assert "corrected with" not in message
