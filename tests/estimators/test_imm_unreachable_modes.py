"""IMM modes that the prior and the Markov matrix leave at probability 0 are said so.

``--set transition_stay=1`` on ``three_tank_hstf`` (prior on mode '2') held mode 2 over the
whole log; the report gave its 26.9 % mode accuracy with only a warning that the innovations
were large ("a scaled sensor, or more noise than the model's?").
"""

from __future__ import annotations

import numpy as np
import pytest

from hybridlog.estimators.filter_options import ImmOptions
from hybridlog.estimators.imm import run_imm, stream_imm, unreachable_modes
from hybridlog.model.loader import load_model
from hybridlog.simulate import simulate


def test_unreachable_modes_is_the_complement_of_what_the_prior_reaches() -> None:
    prior = np.array([1.0, 0.0, 0.0])
    chain = np.array([[0.9, 0.1, 0.0], [0.0, 0.9, 0.1], [0.0, 0.0, 1.0]])
    assert unreachable_modes(prior, chain) == []  # 3 is reached through 2
    assert unreachable_modes(prior, np.eye(3)) == [1, 2]
    no_way_back = np.array([[1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 0.5, 0.5]])
    assert unreachable_modes(np.array([0.0, 1.0, 0.0]), no_way_back) == [2]
    assert unreachable_modes(np.full(3, 1 / 3), np.eye(3)) == []


@pytest.mark.parametrize("stream", [False, True])
def test_a_markov_matrix_that_never_leaves_the_prior_mode_is_a_warning(stream: bool) -> None:
    model = load_model("three_tank_hstf")
    signals = simulate(model, schedule="2:80,1:120,3:100", seed=1000).signals(model)
    held = ImmOptions(transition_stay=1.0)
    if stream:
        chunks = list(stream_imm(model, signals, held, rows=100))
        results = chunks
    else:
        results = [run_imm(model, signals, held)]
    for result in results:
        assert np.all(result.modes == model.mode_ids.index("2"))
        (note,) = [n for n in result.notes if "can never be estimated" in n]
        assert note.startswith("WARNING: modes '1', '3' can never be estimated: the prior")
        assert "transition_stay = 1" in note and "from '2'" in note
    moving = run_imm(model, signals, ImmOptions(transition_stay=0.99))
    assert not [n for n in moving.notes if "can never be estimated" in n]
