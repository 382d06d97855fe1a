"""The outputs an estimate explains, ``ŷ = h_q̂(x̂, u)`` (``hybridlog.estimators.explained``).

A run with an offline pass carries them for its own estimate and the filter's, computed where
the estimate is made (the registry's run, in the estimators' worker of a command), so that
the process writing the report need not load the model's compiled ``h``; the report takes
them from the result.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hybridlog.estimators.explained import explained_outputs
from hybridlog.estimators.registry import prepare
from hybridlog.estimators.result import EstimationResult
from hybridlog.model.loader import load_model
from hybridlog.report import build_report
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import simulate


def test_explained_outputs_are_h_of_the_estimate_in_its_mode() -> None:
    """Through the compiled h of a linear model: y = C_q x + D_q u + d_q, and the plain loop."""
    model = load_model("double_cart_case1")
    n = 50
    rng = np.random.default_rng(3)
    modes = rng.integers(0, model.n_modes, size=n).astype(np.int64)
    n_x, n_y = model.n_states, model.n_outputs
    result = EstimationResult(
        estimator="imm", options={}, time=np.arange(n) * model.dt, mode_ids=model.mode_ids,
        state_names=tuple(model.states), output_names=tuple(model.outputs), modes=modes,
        mode_probabilities=np.eye(model.n_modes)[modes], state_means=rng.normal(size=(n, n_x)),
        state_variances=np.ones((n, n_x)), output_predictions=np.zeros((n, n_y)),
    )  # fmt: skip
    signals = AlignedSignals(
        source="x.csv", time=result.time, input_names=tuple(model.inputs),
        output_names=tuple(model.outputs), inputs=rng.normal(size=(n, model.n_inputs)),
        outputs=np.zeros((n, model.n_outputs)),
    )  # fmt: skip
    linear = model.linear_modes()
    expected = np.array(
        [
            linear[q].C @ result.state_means[k] + linear[q].D @ signals.inputs[k]
            + linear[q].output_offset
            for k, q in enumerate(modes)
        ]
    )  # fmt: skip
    compiled = explained_outputs(model, result, signals)
    plain = explained_outputs(model, result, signals, jit=False)
    assert compiled is not None and plain is not None
    np.testing.assert_allclose(compiled, expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(compiled, plain)
    other = dataclasses.replace(result, mode_ids=("a", "b"))
    assert explained_outputs(model, other, signals) is None


@pytest.mark.parametrize(
    ("name", "overrides"),
    [
        ("three_tank_hstf", {"smooth": True}),
        ("three_tank_hstf", {"mode_sequence": "viterbi"}),
        ("double_cart_case1", {"smooth": True}),  # state-driven: the modes are moved first
    ],
)
def test_a_run_with_an_offline_pass_carries_the_outputs_each_side_explains(
    name: str, overrides: dict[str, object]
) -> None:
    model = load_model(name)
    signals = simulate(model, steps=299, seed=4).signals(model, source="test")
    prepared = prepare(model, "imm", overrides)
    result = prepared.run(model, signals)
    post = result.post_processing
    assert post is not None and post.explained is not None and post.filtered_explained is not None
    np.testing.assert_array_equal(post.explained, explained_outputs(model, result, signals))
    filtered = explained_outputs(model, post.filtered, signals)
    np.testing.assert_array_equal(post.filtered_explained, filtered)
    (whole,) = prepared.stream(model, signals, rows=64)  # a whole result, through run
    assert whole.post_processing is not None
    np.testing.assert_array_equal(whole.post_processing.explained, post.explained)
    assert prepare(model, "imm", {}).run(model, signals).post_processing is None


def test_moving_the_modes_drops_the_outputs_they_explained() -> None:
    model = load_model("double_cart_case1")
    signals = simulate(model, steps=99, seed=1).signals(model, source="test")
    prepared = prepare(model, "imm", {"smooth": True})
    raw = prepared.estimator.run_function(model, signals, prepared.options)
    assert raw.post_processing is not None
    explained = explained_outputs(model, raw, signals)
    carrying = dataclasses.replace(
        raw,
        post_processing=dataclasses.replace(
            raw.post_processing, explained=explained, filtered_explained=explained
        ),
    )
    moved = carrying.with_modes_of_the_step_from().post_processing
    assert moved is not None and moved.explained is None and moved.filtered_explained is None


def test_the_report_takes_the_outputs_the_result_carries() -> None:
    """Carried outputs equal to the measured ones fit them exactly: the report used them."""
    model = load_model("three_tank_hstf")
    signals = simulate(model, steps=299, seed=4).signals(model, source="test")
    result = prepare(model, "imm", {"smooth": True}).run(model, signals)
    assert result.post_processing is not None
    exact = dataclasses.replace(
        result,
        post_processing=dataclasses.replace(result.post_processing, explained=signals.outputs),
    )
    dt = float(model.dt)
    built = build_report(exact, signals, log="t.csv", model_name="m", dt=dt, model=model)
    assert built.smoothing is not None
    assert built.smoothing.smoothed.fit == pytest.approx(100.0)
    assert built.smoothing.filtered.fit is not None and built.smoothing.filtered.fit < 100.0
    computed = build_report(result, signals, log="t.csv", model_name="m", dt=dt, model=model)
    assert computed.smoothing is not None
    assert computed.smoothing.smoothed.fit is not None and computed.smoothing.smoothed.fit < 100.0
