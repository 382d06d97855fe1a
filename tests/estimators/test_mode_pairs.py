"""The IMM on a state-driven model whose output equations differ by mode: the mode pairs.

``y(k)`` follows the mode of the step from ``x(k)`` (paper 001 eq. (1)); the filter weighs it
with the mode of the step into ``x(k)`` (paper 000 eq. (2)).  Moving the modes a sample
earlier cannot mend the output equation the filter applied at a switch; running on the pairs
``(mode into x(k), mode from x(k))`` does (:mod:`hybridlog.estimators.mode_pairs`).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.errors import DivergenceError
from hybridlog.estimators.filter_options import ImmOptions, imm_memory
from hybridlog.estimators.imm import run_imm
from hybridlog.estimators.mode_pairs import PAIRED_MODES_NOTE, pair_mode_model, pair_transitions
from hybridlog.estimators.registry import prepare
from hybridlog.estimators.result import EstimationResult
from hybridlog.model.hybrid_model import Deferred, HybridModel, stored
from hybridlog.model.loader import load_model, parse_model
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import simulate
from tests.estimators.test_mode_step import SENSOR_BY_MODE


def _sensor_model() -> HybridModel:
    return parse_model(SENSOR_BY_MODE % "2*x")


def _error(result: EstimationResult, signals: AlignedSignals) -> float:
    assert signals.truth_modes is not None
    return float(np.mean(result.modes != signals.truth_modes))


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 4).flatmap(
        lambda n: st.tuples(
            st.lists(
                st.lists(st.floats(0.0, 1.0), min_size=n, max_size=n).filter(
                    lambda row: sum(row) > 0.1
                ),
                min_size=n,
                max_size=n,
            ),
            st.lists(st.floats(0.0, 1.0), min_size=n * n, max_size=n * n).filter(
                lambda p: sum(p) > 0.1
            ),
        )
    )
)
def test_the_pairs_chain_and_their_ends_follow_the_markov_matrix(
    drawn: tuple[list[list[float]], list[float]],
) -> None:
    """``Π₂`` is a Markov matrix whose pairs chain (``a->b`` only to ``b->c``), and the
    distribution of the pairs' ends evolves by ``Π`` whatever the pairs' distribution."""
    rows, weights = drawn
    transitions = np.array(rows) / np.array(rows).sum(axis=1, keepdims=True)
    n = transitions.shape[0]
    paired = pair_transitions(transitions)
    assert paired.shape == (n * n, n * n)
    np.testing.assert_allclose(paired.sum(axis=1), 1.0, atol=1e-12)
    for source in range(n * n):
        for target in range(n * n):
            if source % n != target // n:
                assert paired[source, target] == 0.0
    pairs = np.array(weights) / sum(weights)
    ends_after = (pairs @ paired).reshape(n, n).sum(axis=0)
    ends_before = pairs.reshape(n, n).sum(axis=0)
    np.testing.assert_allclose(ends_after, ends_before @ transitions, atol=1e-12)


def test_a_pair_steps_with_its_first_mode_and_measures_with_its_second() -> None:
    model = _sensor_model()
    pairs = pair_mode_model(model, np.array([[0.9, 0.1], [0.2, 0.8]]))
    assert pairs.mode_ids == ("up->up", "up->down", "down->up", "down->down")
    assert not pairs.state_driven
    up, down = model.modes
    for pair, (step, measure) in zip(
        pairs.modes, [(up, up), (up, down), (down, up), (down, down)], strict=True
    ):
        assert pair.f == step.f and pair.h == measure.h
        assert pair.linear_form is not None and step.linear_form is not None
        np.testing.assert_array_equal(pair.linear_form.A, step.linear_form.A)
        assert measure.linear_form is not None
        np.testing.assert_array_equal(pair.linear_form.C, measure.linear_form.C)
    # the prior's mode 'up' as the pairs' end, shared over their start
    np.testing.assert_allclose(pairs.initial_mode_probabilities, [0.5, 0.0, 0.5, 0.0])


@pytest.mark.parametrize("overrides", [{}, {"smooth": True}, {"mode_sequence": "viterbi"}])
def test_the_pairs_find_the_switches_the_moved_modes_missed(
    overrides: dict[str, object],
) -> None:
    """The filter with moved modes erred on 16-17 % of the samples (12 of 24 switches
    missed); on the pairs, on none of three logs (the smoother and the Viterbi path too)."""
    model = _sensor_model()
    unpaired = dataclasses.replace(model, outputs_differ=False)  # the run before the pairs
    for seed in range(3):
        signals = simulate(model, steps=400, seed=seed).signals(model, source="test")
        prepared = prepare(model, "imm", overrides)
        result = prepared.run(model, signals)
        assert PAIRED_MODES_NOTE in result.notes
        assert result.mode_ids == model.mode_ids
        np.testing.assert_allclose(result.mode_probabilities.sum(axis=1), 1.0, atol=1e-9)
        reported = np.array(result.options["transition_matrix"])  # the model's, not the pairs'
        np.testing.assert_allclose(reported, [[0.95, 0.05], [0.05, 0.95]], atol=1e-12)
        options = ImmOptions(**overrides)  # type: ignore[arg-type]
        moved = run_imm(unpaired, signals, options).with_modes_of_the_step_from()
        assert _error(moved, signals) > 0.1
        assert _error(result, signals) < 0.005
        if result.post_processing is not None:  # the filter's own, read back alike
            assert _error(result.post_processing.filtered, signals) < 0.005


def test_a_streamed_run_on_the_pairs_is_the_whole_run() -> None:
    model = _sensor_model()
    signals = simulate(model, steps=60, seed=1).signals(model, source="test")
    prepared = prepare(model, "imm")
    assert not prepared.moves_modes(model)
    whole = prepared.run(model, signals)
    chunks = list(prepared.stream(model, signals, rows=7))
    assert len(chunks) == 9
    np.testing.assert_array_equal(np.concatenate([c.modes for c in chunks]), whole.modes)
    np.testing.assert_array_equal(
        np.concatenate([c.mode_probabilities for c in chunks]), whole.mode_probabilities
    )
    assert all(PAIRED_MODES_NOTE in c.notes for c in chunks)


def test_the_memory_check_counts_the_pairs() -> None:
    model, n = _sensor_model(), 1000
    smooth = dict(imm_memory(model, ImmOptions(smooth=True), n))
    assert smooth["the smoother's per-mode store"] == 8 * n * 4 * (1 + 1)
    assert smooth["the mode pairs' probabilities"] == 8 * n * 4
    unpaired = dataclasses.replace(model, outputs_differ=False)
    assert "the mode pairs' probabilities" not in dict(imm_memory(unpaired, ImmOptions(), n))


def test_the_pairs_of_a_warm_model_leave_its_expressions_unread(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``dataclasses.replace`` read every field of the model read from the cache, whose
    ``simulation_inputs`` rebuilt it from its text: a warm paired run imported sympy and
    the loader (5.0 s against 3.0 s for the model with one ``h``, from the CLI)."""
    monkeypatch.setenv("HYBRIDLOG_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "sensor.toml"
    path.write_text(SENSOR_BY_MODE % "2*x")
    load_model(str(path))
    warm = load_model(str(path))
    assert isinstance(stored(warm, "simulation_inputs"), Deferred)
    pairs = pair_mode_model(warm, np.array([[0.9, 0.1], [0.2, 0.8]]))
    assert isinstance(stored(warm, "simulation_inputs"), Deferred)
    assert isinstance(stored(pairs, "simulation_inputs"), Deferred)
    assert all(isinstance(stored(m, "h"), Deferred) for m in (*warm.modes, *pairs.modes))
    assert str(pairs.simulation_inputs["u"]) == "0"  # computed when read


def _refusal(text: str) -> str:
    model = _sensor_model()
    signals = simulate(model, steps=20, seed=0).signals(model, source="test")
    broken = parse_model(text)
    with pytest.raises(DivergenceError) as caught:
        prepare(broken, "imm").run(broken, signals)
    return str(caught.value)


@pytest.mark.parametrize(
    ("replaced_text", "named"),
    [
        (('f = ["0.5*x"]', 'f = ["0.5*x + sqrt(x - 0.95)"]'), "modes.down.f[0] = "),
        # NaN only after up's step (x = 0.1), not after down's (x = 0): the pair up->down
        (('h = ["2*x"]', 'h = ["2*x + sqrt(0.05 - x)"]'), "modes.down.h[0] = "),
    ],
)
def test_a_refusal_on_the_pairs_names_the_model_files_key(
    replaced_text: tuple[str, str], named: str
) -> None:
    """It named ``modes.down->up.f[0]``, a key the file does not have."""
    message = _refusal((SENSOR_BY_MODE % "2*x").replace(*replaced_text))
    assert f"(sample 1): the state estimate is not finite; {named}" in message, message
    assert "->" not in message


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_the_hstf_refusal_on_a_paired_model_names_what_the_hstf_evaluated(kernel: str) -> None:
    """The diagnosis took every mode's ``h`` after every mode's ``f`` for any estimator on a
    model the IMM runs on its pairs: the HSTF's refusal named ``modes.a.h[0] = 'sqrt(x1)' is
    nan at x1 = -0.1``, mode b's prediction, which the HSTF never measures with mode a's
    ``h``, in place of the Jacobian its eq. (12) took at the modes' mean prediction."""
    from hybridlog.estimators.filter_options import HstfOptions
    from hybridlog.estimators.hstf import run_hstf
    from tests.estimators.test_numerics_results import SQRT_ONE_MODE, falling

    text = SQRT_ONE_MODE.replace('h = ["sqrt(x1)"]', 'h = ["sqrt(x1)"]\nguard = "x1 >= 0.5"')
    text = text.replace('h = ["x1"]', 'h = ["x1"]\nguard = "x1 < 0.5"')
    model = parse_model(text, origin="models/sqrt.toml")
    assert model.state_driven and model.outputs_differ_by_mode
    with pytest.raises(DivergenceError) as caught:
        run_hstf(model, falling(), HstfOptions(), kernel=kernel)
    message = str(caught.value)
    assert "; the derivative by x1 of modes.a.h[0] = 'sqrt(x1)' is nan at x1 = -0.0017" in (
        message
    ), message
    assert message.endswith(", u = 0.1, the modes' mean prediction (eq. (12))"), message


def test_a_refusal_on_the_pairs_names_the_held_and_the_true_mode_as_the_log_does() -> None:
    """It compared the log's true modes with the pairs' indices and named both by pairs:
    ``it held mode 'down->down' ... where the log's true mode was 'up->up'``.  Nine samples:
    sample 0's mode is the prior's, not an estimate (``vouch._lost_before``)."""
    text = (SENSOR_BY_MODE % "2*x").replace('mode = "up"', 'mode = "down"')
    message = _refusal(f"{text}\n[transitions]\nmatrix = [[1.0, 0.0], [0.0, 1.0]]\n")
    assert "cannot explain the log at t = 10 s (sample 10)" in message, message
    assert (
        "it held mode 'down' over the 9 samples before, where the log's true mode was 'up'"
    ) in message, message


def test_a_kbest_refusal_on_the_pairs_names_the_model_files_modes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The path's EKF that cannot weigh a sample named the pair: ``mode 'up->down''s
    innovation covariance``.  The search drops a hypothesis no update exists for, so its
    path meets one only where every kept hypothesis did (made to here: the row is given)."""
    from hybridlog.estimators import mode_hypotheses

    followed = mode_hypotheses.follow_path

    def unweighed_at_12(*arguments: object) -> int:
        followed(*arguments)  # type: ignore[arg-type]
        return 12

    monkeypatch.setattr(mode_hypotheses, "follow_path", unweighed_at_12)
    model = _sensor_model()
    signals = simulate(model, steps=20, seed=0).signals(model, source="test")
    assert signals.truth_modes is not None
    mode = model.mode_ids[int(signals.truth_modes[12])]
    with pytest.raises(DivergenceError) as caught:
        run_imm(model, signals, ImmOptions(mode_sequence="kbest"), jit=False)
    message = str(caught.value)
    assert f"(sample 12) along its most likely mode path: mode '{mode}' (after a step of " in (
        message
    ), message
    assert "->" not in message, message


PAIRED_SINGULAR = """
name = "paired_singular"
dt = 1.0
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y1", "y2"]
[modes.a]
f = ["x1 + 1", "x2"]
h = ["x1", "x1"]
guard = "x1 >= 0.5"
[modes.b]
f = ["x1 - 1", "x2"]
h = ["x1", "x2*x1"]
guard = "x1 < 0.5"
[noise]
process = 1e-10
measurement = 1e-10
[initial]
state = [1.0, 1.0]
covariance = 1.0
"""


def test_the_singular_innovation_diagnosis_of_a_paired_run_weighs_every_pair() -> None:
    """Each mode's ``S`` is singular after its own step (``a``: two outputs of ``x1``; ``b``:
    ``x1 = 0`` after its step), but ``b``'s outputs after ``a``'s step are not: a run on the
    pairs could weigh the sample, and "every mode's innovation covariance is singular" is
    said only of a run that takes each mode with itself."""
    from hybridlog.estimators.vouch import _innovation_singular

    model = parse_model(PAIRED_SINGULAR)
    assert model.state_driven and model.outputs_differ_by_mode
    n = 3
    signals = AlignedSignals(
        source="s.csv",
        time=np.arange(n, dtype=float),
        input_names=("u",),
        output_names=("y1", "y2"),
        inputs=np.zeros((n, 1)),
        outputs=np.ones((n, 2)),
    )
    before, variance = np.array([1.0, 1.0]), np.array([1e20, 1e20])
    alone = _innovation_singular(model, signals, 1, before, variance)
    assert alone.startswith("every mode's innovation covariance H P Hᵀ + R is singular"), alone
    assert _innovation_singular(model, signals, 1, before, variance, paired=True) == ""
