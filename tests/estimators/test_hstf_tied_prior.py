"""A prior whose largest mode probability is shared: the HSTF says which mode it starts from.

Eq. (40) holds q̂(0) until a posterior reaches θ; a tie silently picked the first mode of the
file (``three_tank_hstf`` with a prior of 0.5, 0.5, 0 held mode 1: 87.0 % mode accuracy on a
1:150,3:150 log, 36.9 % with the prior on mode 2).
"""

from __future__ import annotations

import numpy as np

from hybridlog.estimators.filter_options import HstfOptions
from hybridlog.estimators.hstf import run_hstf
from hybridlog.model.builtins import builtin_text
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.loader import parse_model
from hybridlog.simulate import simulate


def _three_tank(initial_mode: str) -> HybridModel:
    text = builtin_text("three_tank_hstf").replace('mode = "2"', initial_mode)
    return parse_model(text, origin="three_tank_tied.toml")


def test_a_tied_prior_is_a_warning_naming_the_mode_it_starts_from() -> None:
    tied = _three_tank("mode_probabilities = [0.5, 0.5, 0.0]")
    signals = simulate(tied, schedule="1:150,3:150", seed=1002).signals(tied)
    result = run_hstf(tied, signals, HstfOptions())
    (note,) = [n for n in result.notes if "same largest probability" in n]
    assert note.startswith(
        "WARNING: the prior ([initial]) gives modes '1', '2' the same largest probability "
        "(0.5), so q̂(0) is '1', the first of them"
    )
    assert result.modes[0] == 0 and np.mean(result.modes == signals.truth_modes) > 0.8
    chosen = _three_tank('mode = "2"')
    assert not [
        n for n in run_hstf(chosen, signals, HstfOptions()).notes if "largest probability" in n
    ]
