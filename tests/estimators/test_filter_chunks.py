"""A filter's result in chunks: put end to end, the chunks are the whole result, bit for bit.

``run_filter_chunks`` calls a filter's loop once per chunk, each call resuming from the
state the one before left; ``run_filter`` is the same machinery in one chunk.  Both code paths
(``unrolled``, the generated straight-line code; ``loops``, the generic compiled loop) and
the plain-Python reference (``jit=False``) are checked, on logs of 1 to 1000 samples and
chunks of 1 row to more than the log, on the three-tank model (3 states, 3 outputs, 3 modes)
and the double cart (4 states, 1 output, 2 modes).
"""

from dataclasses import replace
from functools import cache

import numpy as np
import pytest

from hybridlog.errors import LogError, ModelError
from hybridlog.estimators.capabilities import Capabilities
from hybridlog.estimators.hstf import FADED_LIKELIHOOD_NOTE, HstfOptions, run_hstf, stream_hstf
from hybridlog.estimators.imm import ImmOptions, run_imm, stream_imm
from hybridlog.estimators.registry import CHUNK_ROWS, ESTIMATORS, Prepared, prepare
from hybridlog.model.cache import load_model
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import simulate
from tests.support.models import POLE

MODELS = ("three_tank_hstf", "double_cart_case1")
FILTERS = {
    "hstf": (run_hstf, stream_hstf, HstfOptions()),
    "imm": (run_imm, stream_imm, ImmOptions()),
}
LENGTHS = (1, 2, 3, 50, 1000)
SHORT = (1, 2, 3, 50)
"""Log lengths the plain-Python reference runs over (it takes milliseconds a step)."""
FIELDS = (
    "modes",
    "mode_probabilities",
    "state_means",
    "state_variances",
    "output_predictions",
    "covariances",
)


@cache
def _log(model_name):
    """The model and a simulated log of 1000 samples (the logs below are its first rows)."""
    model = load_model(model_name)
    return model, simulate(model, steps=999, seed=8).signals(model)


def _head(signals, n):
    return AlignedSignals(
        source=signals.source,
        time=signals.time[:n],
        input_names=signals.input_names,
        output_names=signals.output_names,
        inputs=signals.inputs[:n],
        outputs=signals.outputs[:n],
    )


def _rows(n):
    """Chunk sizes: a row, a few, more than a step's worth, the log but one, the log, more."""
    return sorted({1, 2, 7, 64, n - 1, n, n + 5} - {0})


def _same_bits(a, b):
    """Equal shapes and the same bytes (NaN where the other has NaN, the same NaN)."""
    if a is None or b is None:
        return a is None and b is None
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _check_stream(chunks, whole, signals, rows, model):
    """Consume ``chunks`` as a consumer must (copying each before the next) and check them."""
    n = signals.n_samples
    kept = {field: [] for field in FIELDS}
    runtimes, compiles = [], []
    first = 0
    for index, chunk in enumerate(chunks):
        stop = min(first + rows, n)
        assert chunk.n_samples == stop - first
        assert _same_bits(chunk.time, signals.time[first:stop])
        if index == 0 and n:  # row 0: the prior
            assert np.isnan(chunk.output_predictions[0]).all()
            np.testing.assert_array_equal(chunk.state_means[0], model.initial_state)
            np.testing.assert_array_equal(
                chunk.mode_probabilities[0], model.initial_mode_probabilities
            )
        assert (chunk.estimator, chunk.options, chunk.notes) == (
            whole.estimator,
            whole.options,
            whole.notes,
        )
        assert (chunk.mode_ids, chunk.state_names, chunk.output_names) == (
            whole.mode_ids,
            whole.state_names,
            whole.output_names,
        )
        assert chunk.post_processing is None
        for field in FIELDS:
            value = getattr(chunk, field)
            kept[field].append(None if value is None else value.copy())
        runtimes.append(chunk.runtime_s)
        compiles.append(chunk.compile_s)
        first = stop
    assert first == n
    assert len(runtimes) == max(1, -(-n // rows))
    assert runtimes == sorted(runtimes) and runtimes[0] >= 0.0  # cumulative
    assert len(set(compiles)) == 1  # the set-up's, once
    for field in FIELDS:
        parts = kept[field]
        joined = None if parts[0] is None else np.concatenate(parts)
        assert _same_bits(joined, getattr(whole, field)), field


@pytest.mark.parametrize("store_covariances", [False, True])
@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
@pytest.mark.parametrize("filter_name", sorted(FILTERS))
@pytest.mark.parametrize("model_name", MODELS)
def test_chunks_end_to_end_are_the_whole_result_bit_for_bit(
    model_name, filter_name, kernel, store_covariances
):
    model, log = _log(model_name)
    run, stream, options = FILTERS[filter_name]
    for n in LENGTHS:
        signals = _head(log, n)
        whole = run(model, signals, options, kernel=kernel, store_covariances=store_covariances)
        for rows in _rows(n):
            chunks = stream(
                model,
                signals,
                options,
                rows=rows,
                kernel=kernel,
                store_covariances=store_covariances,
            )
            _check_stream(chunks, whole, signals, rows, model)


@pytest.mark.parametrize("store_covariances", [False, True])
@pytest.mark.parametrize("filter_name", sorted(FILTERS))
@pytest.mark.parametrize("model_name", MODELS)
def test_the_plain_python_reference_in_chunks_is_its_whole_result(
    model_name, filter_name, store_covariances
):
    model, log = _log(model_name)
    run, stream, options = FILTERS[filter_name]
    for n in SHORT:
        signals = _head(log, n)
        whole = run(model, signals, options, jit=False, store_covariances=store_covariances)
        for rows in _rows(n):
            chunks = stream(
                model, signals, options, rows=rows, jit=False, store_covariances=store_covariances
            )
            _check_stream(chunks, whole, signals, rows, model)


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
@pytest.mark.parametrize("filter_name", sorted(FILTERS))
def test_the_chunks_share_buffers_of_one_chunk(filter_name, kernel):
    model, signals = _log("three_tank_hstf")
    _, stream, options = FILTERS[filter_name]
    chunks = stream(model, signals, options, rows=64, kernel=kernel, store_covariances=True)
    opening = next(chunks)
    assert opening.n_samples == 64 and opening.covariances.shape[0] == 64
    # two sets of buffers of one chunk, taken in turn: the next chunk is computed into the
    # other set while the caller takes this one
    sets = [opening, next(chunks)]
    for field in FIELDS:
        assert not np.shares_memory(getattr(sets[0], field), getattr(sets[1], field)), field
    for index, chunk in enumerate(chunks, start=2):
        for field in FIELDS:
            assert np.shares_memory(getattr(chunk, field), getattr(sets[index % 2], field)), field
    (whole,) = stream(model, _head(signals, 50), options, rows=64, kernel=kernel)
    assert whole.n_samples == 50 and whole.covariances is None


def test_the_hstf_chunks_carry_the_faded_likelihood_note_as_the_whole_run():
    model, signals = _log("three_tank_hstf")
    for options in (HstfOptions(), HstfOptions(likelihood="unfaded")):
        notes = {chunk.notes for chunk in stream_hstf(model, signals, options, rows=300)}
        assert notes == {run_hstf(model, signals, options).notes}
        assert (FADED_LIKELIHOOD_NOTE in notes.pop()) == (options.likelihood == "faded")


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
@pytest.mark.parametrize("filter_name", sorted(FILTERS))
def test_a_diverging_stream_names_the_sample_of_the_log(filter_name, kernel):
    model = parse_model(POLE, origin="models/pole.toml")
    n = 30
    inputs = np.ones((n, 1))
    inputs[11] = 0.0  # x(12) = x(11)/0
    signals = AlignedSignals(
        source="sim",
        time=np.arange(n, dtype=float),
        input_names=("u",),
        output_names=("y",),
        inputs=inputs,
        outputs=np.full((n, 1), 2.0),
    )
    _, stream, options = FILTERS[filter_name]
    chunks = stream(model, signals, options, rows=5, kernel=kernel)
    assert [next(chunks).time[0] for _ in range(2)] == [0.0, 5.0]
    with pytest.raises(
        ModelError,
        match=rf"^models/pole\.toml: {filter_name} diverged at t = 12 s \(sample 12\)",
    ):
        next(chunks)
    assert next(chunks, None) is None


def test_chunks_have_at_least_one_row():
    model, signals = _log("three_tank_hstf")
    with pytest.raises(ValueError, match="rows must be at least 1"):
        stream_hstf(model, signals, HstfOptions(), rows=0)
    with pytest.raises(ValueError, match="rows must be at least 1"):
        prepare(model, "hstf").streamed(model, 10, rows=0)


def test_prepared_stream_gives_the_filters_chunks_and_says_when():
    model, signals = _log("three_tank_hstf")
    assert CHUNK_ROWS == 65536
    for name in ("hstf", "imm"):
        prepared = prepare(model, name)
        whole = prepared.run(model, signals)
        for rows in (64, 999, 1000):
            chunks = list(prepared.stream(model, signals, rows=rows))
            assert prepared.streamed(model, signals.n_samples, rows) == (len(chunks) > 1)
            assert chunks[-1].n_samples == signals.n_samples - (len(chunks) - 1) * rows
        (one,) = prepared.stream(model, signals)  # CHUNK_ROWS: more than the log
        for field in FIELDS:
            assert _same_bits(getattr(one, field), getattr(whole, field)), field
        assert prepared.streamed(model, CHUNK_ROWS + 1) and not prepared.streamed(model, CHUNK_ROWS)


def test_prepared_stream_of_an_estimator_without_stream_is_its_whole_result_in_chunks():
    model, signals = _log("three_tank_hstf")
    whole_only = Prepared(replace(ESTIMATORS["hstf"], stream=""), HstfOptions())
    chunks = list(whole_only.stream(model, signals, rows=7))
    assert len(chunks) == -(-signals.n_samples // 7)
    whole = whole_only.run(model, signals)
    for field in FIELDS:
        parts = [getattr(chunk, field) for chunk in chunks]
        if getattr(whole, field) is None:  # covariances, not asked for
            assert all(part is None for part in parts), field
        else:
            assert _same_bits(np.concatenate(parts), getattr(whole, field)), field
    assert not whole_only.streamed(model, signals.n_samples, 7)  # computed whole


@pytest.mark.parametrize("overrides", [{"smooth": True}, {"mode_sequence": "viterbi"}])
def test_an_imm_with_an_offline_pass_streams_its_whole_result_in_chunks(overrides):
    model, signals = _log("three_tank_hstf")
    prepared = prepare(model, "imm", overrides)
    chunks = list(prepared.stream(model, signals, rows=7))
    assert all(chunk.post_processing is not None for chunk in chunks)
    assert sum(chunk.n_samples for chunk in chunks) == signals.n_samples
    joined = np.concatenate([chunk.modes for chunk in chunks])
    np.testing.assert_array_equal(joined, prepared.run(model, signals).modes)
    assert not prepared.streamed(model, signals.n_samples, 7)  # computed whole


def test_prepared_stream_checks_the_log_at_the_call():
    model, log = _log("three_tank_hstf")
    without_modes = _head(log, 100)  # no truth.mode: the switching signal is missing
    needs_modes = replace(
        ESTIMATORS["hstf"], capabilities=Capabilities(needs_switching_signal=True)
    )
    with pytest.raises(LogError, match="needs the switching signal"):
        Prepared(needs_modes, HstfOptions()).stream(model, without_modes)


@pytest.mark.parametrize("filter_name", ["hstf", "imm"])
def test_a_caller_that_stops_early_leaves_no_loop_running(filter_name):
    """The next chunk is computed ahead in a thread: closing the stream waits for it."""
    import threading

    model, signals = _log("three_tank_hstf")
    _, stream, options = FILTERS[filter_name]
    chunks = stream(model, signals, options, rows=64)
    next(chunks)
    chunks.close()
    assert not [t for t in threading.enumerate() if t.name.endswith("-chunk")]
