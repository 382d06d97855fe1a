"""``unknown-mode``'s output prediction is made before the sample it predicts (SPEC §8).

MSE, VAF and fit score ``ŷ(k)`` against ``y(k)``.  The estimator reported the ``ŷ(k|k-1)`` of
the most likely hypothesis *after* step k, which ``y(k)`` itself picks (paper 002 eq. (5)):
the kept prediction nearest the measurement, and where a spike made an unknown component the
most likely, no prediction at all (the sample left out of the metrics).  A change of ``y(k)``
changed ``ŷ(k)``.
"""

from dataclasses import replace

import numpy as np
import pytest

from hybridlog.estimators.cpha.options import UnknownModeOptions
from hybridlog.estimators.cpha.unknown_mode import run_unknown_mode
from hybridlog.model.loader import parse_model
from tests.support.cpha import CPHA_EXAMPLE, cpha_log

SPIKE_AT = 40


@pytest.mark.parametrize("sequence", ["argmax", "kbest"])
def test_a_spike_at_a_sample_changes_no_prediction_up_to_it(sequence):
    model = parse_model(CPHA_EXAMPLE)
    signals = cpha_log(model, 60, seed=3)
    spiked = signals.outputs.copy()
    spiked[SPIKE_AT, 0] += 3.0  # 30 sigma of y_c1's noise: only A1 unknown explains it
    options = UnknownModeOptions(mode_sequence=sequence)
    plain = run_unknown_mode(model, signals, options)
    hit = run_unknown_mode(model, replace(signals, outputs=spiked), options)
    a1 = {c.name: c for c in hit.timeline_columns}["mode.A1"]
    assert a1.labels[a1.values[SPIKE_AT]] == "unknown"  # the spike changed the estimate there
    before = slice(0, SPIKE_AT + 1)
    assert np.array_equal(
        hit.output_predictions[before], plain.output_predictions[before], equal_nan=True
    )
    assert np.isfinite(hit.output_predictions[1 : SPIKE_AT + 1]).all()
    # out of A3 = unknown (the estimate after the spike) staying and m31 are equally likely
    # (0.5 each): the estimate's own mode is held, not the target listed first, so y_c2,
    # whose equation A3 unknown leaves out, is not predicted
    a3 = {c.name: c for c in hit.timeline_columns}["mode.A3"]
    assert a3.labels[a3.values[SPIKE_AT + 1]] == "unknown"
    assert np.isnan(hit.output_predictions[SPIKE_AT + 2, 1])
