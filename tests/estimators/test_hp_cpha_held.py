"""A state the reported hypothesis held rather than estimated is named in a warning.

Paper 002 §3.1 holds the mean of a state in no filter cluster and grows its variance; the
report scored that held value (the initial state, for a state no cluster ever held) against
the log's true state as an estimate, without a word.
"""

import numpy as np

from hybridlog.estimators.cpha.unknown_mode import UnknownModeOptions, run_unknown_mode
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals
from tests.estimators.test_hp_cpha_solving import model_text


def run(text, options):
    model = parse_model(text)
    n = 30
    u = 1.0 + 0.5 * np.sin(np.arange(n) / 5.0)
    t = np.arange(n, dtype=np.float64)
    log = AlignedSignals("log.csv", t, model.inputs, model.outputs, u[:, None], u[:, None].copy())
    return run_unknown_mode(model, log, options)


def held_notes(result):
    return [note for note in result.notes if "a reported state no filter estimated" in note]


def test_an_unobservable_state_is_named_on_every_sample_it_was_held():
    text = model_text("x1[k] = 0.8*x1[k-1] + u1[k-1]", "y1 = u1")
    for sequence in ("argmax", "kbest"):
        result = run(text, UnknownModeOptions(unknown_mode=False, mode_sequence=sequence))
        (note,) = held_notes(result)
        assert note.startswith("WARNING: a reported state no filter estimated: x1 on 30 of 30 ")
        assert "the state RMSE scores the held value" in note
        # the warning is true: the mean never moved from the initial state
        assert (result.state_means[:, 0] == 0.0).all()
        if result.post_processing is not None:
            assert held_notes(result.post_processing.filtered) == [note]


def test_an_estimated_state_has_no_warning():
    text = model_text("x1[k] = 0.8*x1[k-1] + u1[k-1]", "y1 = x1")
    result = run(text, UnknownModeOptions(unknown_mode=False))
    assert held_notes(result) == []
