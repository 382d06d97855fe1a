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
from hybridlog.report.build import ReportBuilder
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
    chunks = [c.post_processing for c in prepared.stream(model, signals, rows=64)]
    assert len(chunks) == 5 and all(c is not None for c in chunks)
    for field in ("explained", "filtered_explained"):
        joined = np.concatenate([getattr(c, field) for c in chunks if c is not None])
        np.testing.assert_array_equal(joined, getattr(post, field))
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


def _fields(result: EstimationResult) -> dict[str, object]:
    """Every per-sample array of a result, its filter's and its explained outputs included."""
    arrays: dict[str, object] = {
        name: getattr(result, name)
        for name in (
            "time",
            "modes",
            "mode_probabilities",
            "state_means",
            "state_variances",
            "output_predictions",
        )
    }
    post = result.post_processing
    if post is not None:
        arrays.update({f"filtered.{k}": v for k, v in _fields(post.filtered).items()})
        arrays["explained"], arrays["filtered_explained"] = post.explained, post.filtered_explained
    return arrays


@pytest.mark.parametrize(
    ("name", "estimator", "overrides"),
    [
        ("three_tank_hstf", "imm", {"smooth": True}),
        ("three_tank_hstf", "imm", {"mode_sequence": "kbest"}),
        ("double_cart_case1", "hstf", {}),  # state-driven: computed whole, modes moved
        ("double_cart_case1", "chiu", {}),  # no stream of its own
    ],
)
@pytest.mark.parametrize("rows", [1, 7, 64, 10_000])
def test_a_whole_result_comes_in_chunks_of_its_rows(
    name: str, estimator: str, overrides: dict[str, object], rows: int
) -> None:
    """A result computed whole crosses in chunks (the report takes one while the next comes):
    joined, they are the whole result, bit for bit; and the report built from the chunks is
    the report of the whole result."""
    model = load_model(name)
    signals = simulate(model, steps=199, seed=5).signals(model, source="test")
    prepared = prepare(model, estimator, overrides)
    whole = prepared.run(model, signals)
    chunks = list(prepared.stream(model, signals, rows=rows))
    assert [c.n_samples for c in chunks] == [
        min(rows, signals.n_samples - start) for start in range(0, signals.n_samples, rows)
    ]
    expected = _fields(whole)
    for key, value in expected.items():
        parts = [_fields(c)[key] for c in chunks]
        if value is None:
            assert all(part is None for part in parts), key
        else:
            np.testing.assert_array_equal(np.concatenate(parts), value, err_msg=key)
    dt = float(model.dt)
    builder = ReportBuilder(signals, log="t.csv", dt=dt, model=model)
    for chunk in chunks:
        builder.add(chunk)
    chunked = builder.report(model_name="m").to_dict()
    at_once = build_report(whole, signals, log="t.csv", model_name="m", dt=dt, model=model)
    timed = ("runtime_s", "compile_s", "samples_per_s")  # two runs: the clocks differ
    assert {k: v for k, v in chunked.items() if k not in timed} == {
        k: v for k, v in at_once.to_dict().items() if k not in timed
    }
    assert ("smoothing" in chunked) == (whole.post_processing is not None)


def test_a_run_whose_chunks_differ_in_their_offline_pass_is_a_programming_error() -> None:
    model = load_model("three_tank_hstf")
    signals = simulate(model, steps=99, seed=2).signals(model, source="test")
    smoothed = prepare(model, "imm", {"smooth": True}).run(model, signals)
    plain = dataclasses.replace(smoothed, post_processing=None)
    for first, second in ((smoothed, plain), (plain, smoothed)):
        builder = ReportBuilder(signals, log="t.csv", dt=float(model.dt), model=model)
        builder.add(first.rows(0, 50))
        with pytest.raises(ValueError, match="offline pass"):
            builder.add(second.rows(50, 100))
