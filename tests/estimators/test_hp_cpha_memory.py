"""What a long ``unknown-mode`` run keeps per sample is what the memory check is told.

The run kept each step's most likely hypothesis object to the end (its full ``P``, ``ŷ`` and
cluster steps), about 2 KB a sample for a one-state model, and the k-best histories in lists
of tuples and an array per step, while the memory check was told of the result's 32 bytes a
sample and, with ``kbest``, less than half the histories: a long log passed the check and
then ran out of memory.  Measured with tracemalloc (allocations, not time): the growth of the
peak from a run of N to one of 2N samples, per added sample.
"""

import tracemalloc

import numpy as np
import pytest

from hybridlog.estimators.cpha.options import unknown_mode_memory
from hybridlog.estimators.cpha.unknown_mode import UnknownModeOptions, run_unknown_mode
from hybridlog.estimators.footprint import result_bytes
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals
from tests.estimators.test_hp_cpha_unexplained import TO_UNKNOWN_ONLY

MODEL = TO_UNKNOWN_ONLY.replace("to = {unknown = 1.0}", "to = {b = 0.01}").replace(
    "[[components.plant.transitions]]",
    '[components.plant.modes.b]\nequations = ["x1[k] = 0.5*x1[k-1] + u1[k-1]", "y1 = x1"]\n\n'
    "[[components.plant.transitions]]",
)


def signals(model, n):
    rng = np.random.default_rng(1)
    u = 1.0 + 0.5 * np.sin(np.arange(n) / 7.0)
    x, ys = 0.0, []
    for k in range(n):
        if k:
            x = 0.8 * x + u[k - 1] + rng.normal(0.0, 0.1)
        ys.append(x + rng.normal(0.0, 0.1))
    t = np.arange(n, dtype=np.float64)
    return AlignedSignals(
        "log.csv", t, model.inputs, model.outputs, u[:, None], np.array(ys)[:, None]
    )


def peak(model, n, options):
    log = signals(model, n)
    tracemalloc.start()
    try:
        run_unknown_mode(model, log, options)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("sequence", ["argmax", "kbest"])
def test_a_run_grows_per_sample_by_about_what_the_memory_check_counts(sequence):
    model = parse_model(MODEL)
    options = UnknownModeOptions(mode_sequence=sequence)
    run_unknown_mode(model, signals(model, 20), options)  # compiled once
    n = 300
    grown = (peak(model, 2 * n, options) - peak(model, n, options)) / n
    told = (result_bytes(model, n) + sum(b for _, b in unknown_mode_memory(model, options, n))) / n
    assert grown < 1.5 * told, (grown, told)
