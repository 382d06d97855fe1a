"""The grid's phase is the held signals' clock, not one output message's jitter.

The grid started at the latest first sample of the inputs and outputs.  When that was a
jittered output message of a topic that starts late and came early (56 ms before its tick
with ``dt = 1 s``), the whole grid sat just before the real ticks, and the inputs and the
true mode, held from their last sample at or before each point, came out one step behind
the outputs, which take the nearest sample: the IMM found 2 of 19 switches of a three-tank
log instead of 19.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.io.align import align_signals
from hybridlog.io.source import LabelSeries, Series
from hybridlog.signals import AlignedSignals

N, DT_NS, SWITCH = 60, 1_000_000_000, 20


def _log(first_late_ns: int, *, epoch_ns: int = 0, seed: int = 3) -> AlignedSignals:
    """u, the true mode and y1 from tick 0; y3, every third step, from tick 9.

    u and the true mode are on the ticks; y1 and y3 jitter within ±10 % of a step; y3's
    first message is ``first_late_ns`` off its tick.
    """
    rng = np.random.default_rng(seed)
    ticks = epoch_ns + np.arange(N, dtype=np.int64) * DT_NS
    mode = (np.arange(N) >= SWITCH).astype(np.int32)
    u = np.where(mode == 1, 5.0, -5.0) + np.arange(N)
    y1 = ticks + rng.integers(-DT_NS // 10, DT_NS // 10, N)
    y3 = ticks[9::3] + rng.integers(-DT_NS // 10, DT_NS // 10, ticks[9::3].size)
    y3[0] = ticks[9] + first_late_ns
    return align_signals(
        source="s",
        dt=1.0,
        inputs={"u": Series("u", ticks, u)},
        outputs={
            "y1": Series("y1", y1, np.arange(N, dtype=np.float64)),
            "y3": Series("y3", y3, np.arange(9, N, 3, dtype=np.float64)),
        },
        truth_mode=LabelSeries("mode", ticks, mode, ("a", "b")),
        max_gap=10.0,
    )


def test_an_early_first_message_does_not_put_the_inputs_a_step_behind() -> None:
    early = _log(-56_000_000)
    assert early.time[0] == 9.0  # the tick, not the message at 8.944 s
    at_switch = int(np.flatnonzero(early.time == SWITCH)[0])
    assert early.inputs[at_switch, 0] == 5.0 + SWITCH  # u of that tick, not of the one before
    assert early.truth_modes is not None
    assert early.truth_modes[at_switch] == 1
    assert early.truth_modes[at_switch - 1] == 0


def test_the_log_aligns_as_the_one_whose_first_message_came_late() -> None:
    early, late = _log(-56_000_000), _log(55_000_000)
    np.testing.assert_array_equal(early.time, late.time)
    np.testing.assert_array_equal(early.inputs, late.inputs)
    np.testing.assert_array_equal(early.truth_modes, late.truth_modes)
    np.testing.assert_array_equal(early.outputs, late.outputs)  # y3's first one: nearest


def test_outputs_half_a_step_off_the_inputs_clock_keep_their_own_phase() -> None:
    # y is sampled around the half steps: on the inputs' ticks every point would tie
    aligned = align_signals(
        source="s",
        dt=1.0,
        inputs={"u": Series("u", np.arange(5) * DT_NS, np.arange(5.0))},
        outputs={"y": Series("y", np.array([1.5, 2.6, 3.4, 4.5]) * 1e9, np.arange(4.0))},
    )
    np.testing.assert_array_equal(aligned.time, [1.5, 2.5, 3.5, 4.5])


@settings(max_examples=60, deadline=None)
@given(
    first_late_ms=st.integers(-249, 249),
    epoch_s=st.sampled_from([0, 1_700_000_000]),
    seed=st.integers(0, 2**16),
)
def test_output_jitter_never_shifts_the_hold_by_a_step(
    first_late_ms: int, epoch_s: int, seed: int
) -> None:
    aligned = _log(first_late_ms * 1_000_000, epoch_ns=epoch_s * DT_NS, seed=seed)
    ticks = np.rint(aligned.time - epoch_s).astype(np.int64)
    # on the ticks, within the clock tolerance dt/1000 (a first message 1 ms off is at it)
    np.testing.assert_allclose(aligned.time - epoch_s, ticks, rtol=0, atol=1.001e-3)
    u = np.where(ticks >= SWITCH, 5.0, -5.0) + ticks
    np.testing.assert_array_equal(aligned.inputs[:, 0], u)
    np.testing.assert_array_equal(aligned.truth_modes, (ticks >= SWITCH).astype(np.int64))
