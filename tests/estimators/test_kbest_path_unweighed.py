"""The k-best path's EKF where its mode's innovation covariance admits no update.

``mode_hypotheses.follow_path`` kept its prediction silently where ``S = H P Hᵀ + R`` of the
path's mode was not positive definite (or, overflowed to infinity, weighed nothing): the path's
estimates there were predictions reported as estimates of the log.  It now returns the first
such sample that measured an output, and ``--mode-sequence kbest`` refuses the run there
(``smoothing._refuse_unweighed_path``), as the forward filters refuse a sample no mode could
weigh (``vouch._first_unweighed``).
"""

from dataclasses import replace

import numpy as np
import pytest

from hybridlog.errors import DivergenceError
from hybridlog.estimators.common import FilterRun
from hybridlog.estimators.mode_hypotheses import follow_path
from hybridlog.estimators.smoothing import _refuse_unweighed_path
from hybridlog.jit import compile_for
from hybridlog.model.compiled import compile_model
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals

N = 5


def _model(noise: str, covariance: str):
    return parse_model(
        'dt = 1.0\nstates = ["x1"]\ninputs = ["u"]\noutputs = ["y1", "y2"]\n\n'
        '[modes.a]\nf = ["x1 + u"]\nh = ["x1", "x1"]\n\n'
        '[modes.b]\nf = ["x1"]\nh = ["x1", "2*x1"]\n\n'
        f"[noise]\nprocess = 0.0\nmeasurement = {noise}\n\n"
        f"[initial]\nstate = [0.0]\ncovariance = {covariance}\n",
        origin="path.toml",
    )


def _signals(unmeasured: bool = False) -> AlignedSignals:
    signals = AlignedSignals(
        source="path.csv",
        time=np.arange(N, dtype=float),
        input_names=("u",),
        output_names=("y1", "y2"),
        inputs=np.zeros((N, 1)),
        outputs=np.full((N, 2), 5.0),
    )
    if unmeasured:
        mask = np.zeros((N, 2), dtype=bool)
        mask[1] = True
        signals = replace(signals, unmeasured_outputs=mask)
    return signals


def _follow(
    noise: str, path: list[int], *, covariance: str = "1.0", unmeasured: bool = False, jit=False
):
    model = _model(noise, covariance)
    signals = _signals(unmeasured)
    compiled = compile_model(model, jit=jit)
    run = FilterRun.of(model, signals, "imm")
    means = np.zeros((N, 1))
    covariances = np.zeros((N, 1, 1))
    path_array = np.asarray(path, dtype=np.int64)
    followed = (compiled.f, compiled.F, compiled.h, compiled.H, run, path_array, means, covariances)
    first = (compile_for(follow_path, followed) if jit else follow_path)(*followed)
    return model, signals, path_array, first, means


@pytest.mark.parametrize("jit", [False, True])
def test_a_path_whose_mode_has_a_singular_innovation_covariance_is_refused(jit):
    model, signals, path, first, means = _follow("1e-10", [0] * N, covariance="1e20", jit=jit)
    assert first == 1  # H P Hᵀ rounds R away: S singular as computed
    assert means[1, 0] == 0.0  # the prediction stood there
    with pytest.raises(DivergenceError) as caught:
        _refuse_unweighed_path(model, signals, path, first)
    assert str(caught.value) == (
        "path.toml: imm (mode_sequence kbest) cannot weigh the measurement at t = 1 s "
        "(sample 1) along its most likely mode path: mode 'a''s innovation covariance "
        "H P Hᵀ + R is not finite and positive definite in double precision there, so no "
        "update exists"
    )


def test_a_path_that_can_weigh_every_sample_returns_none():
    *_, first, means = _follow("1e-2", [0, 1, 1, 0, 0])
    assert first == -1
    assert np.isfinite(means).all()
    assert (means[1:, 0] > 2.5).all()  # every update drew the prior 0 towards y = 5


def test_a_sample_measuring_nothing_has_nothing_to_weigh():
    *_, first, _ = _follow("1e-2", [0] * N, unmeasured=True)
    assert first == -1
