"""``--sort`` with ``--drop-nonfinite``: a NaN of a repeated time never drops a measurement.

``--sort`` keeps the last sample of a time; ``--drop-nonfinite`` drops NaN samples.  A NaN
written after a measurement of the same time was kept as the last and then dropped, and the
measurement with it: the grid point read a sample a step away (bridged), and with
``--max-gap 0`` the log was refused as having "no usable sample" where it has one.  The NaN
is dropped (``nonfinite_dropped``) and the measurement kept, in tables and messages alike.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hybridlog.io import ReadOptions, SignalSpec, load_signals
from tests.support.logfiles import Channel, float64_cdr, write_mcap

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=1.0)
OPTIONS = ReadOptions(sort=True, drop_nonfinite=True)


@pytest.mark.parametrize("rows", [["1,0,1", "1,,nan"], ["1,0,nan", "1,,1"]])
def test_a_table_keeps_the_measurement_of_a_time_beside_a_nan(
    tmp_path: Path, rows: list[str]
) -> None:
    log = tmp_path / "log.csv"
    log.write_text("\n".join(["t,u,y", "0,0,0", *rows, "2,0,2", "3,0,3"]) + "\n")
    notes: dict[str, object] = {}
    signals = load_signals(log, SPEC, OPTIONS, notes=notes)
    np.testing.assert_array_equal(signals.outputs[:, 0], [0.0, 1.0, 2.0, 3.0])
    assert signals.unmeasured_outputs is None
    assert notes["nonfinite_dropped"] == {"y": 1}
    assert "values_superseded" not in notes
    strict = load_signals(log, SPEC, ReadOptions(sort=True, drop_nonfinite=True, max_gap=0))
    np.testing.assert_array_equal(strict.outputs[:, 0], [0.0, 1.0, 2.0, 3.0])


def test_a_topic_keeps_the_measurement_of_a_time_beside_a_nan(tmp_path: Path) -> None:
    ns = 1_000_000_000
    channels = [Channel("/u"), Channel("/y")]
    messages = [(0, k * ns, float64_cdr(0.0)) for k in range(4)]
    messages += [(1, k * ns, float64_cdr(float(k))) for k in range(4)]
    messages.insert(6, (1, ns, float64_cdr(float("nan"))))  # after y = 1 at t = 1 s
    log = write_mcap(tmp_path / "log.mcap", channels, messages)
    spec = SignalSpec(
        inputs=("u",),
        outputs=("y",),
        mode_ids=("a",),
        dt=1.0,
        signals={"u": "/u.data", "y": "/y.data"},
    )
    notes: dict[str, object] = {}
    signals = load_signals(log, spec, OPTIONS, notes=notes)
    np.testing.assert_array_equal(signals.outputs[:, 0], [0.0, 1.0, 2.0, 3.0])
    assert signals.unmeasured_outputs is None
    assert notes["nonfinite_dropped"] == {"/y.data": 1}
    assert "duplicates_dropped" not in notes
