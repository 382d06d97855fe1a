"""Float64 seconds too coarse for the log's own steps are refused, naming the cause.

Near t = 1.7e9 s (Unix time) float64 values are 238 ns apart.  A log sampled every 0.1 µs
there was refused as "time repeats" without a word of why, and with ``--sort`` its rows
were merged into fewer, unevenly spaced samples, analysed as if the log had them.  The
same check float32 times had now covers float64 too, against the alignment's tolerance.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=1e-7)


def _write(path: Path, base: float, step: float, n: int = 50) -> Path:
    rows = "".join(f"{base + k * step!r},{k},{k}\n" for k in range(n))
    path.write_text("t,u,y\n" + rows)
    return path


@pytest.mark.parametrize("sort", [False, True])
def test_unix_times_finer_than_float64_are_refused(tmp_path: Path, sort: bool) -> None:
    log = _write(tmp_path / "log.csv", 1.7e9, 1e-7)
    with pytest.raises(LogError) as caught:
        load_signals(log, SPEC, ReadOptions(sort=sort))
    message = str(caught.value)
    assert message.startswith(f"{log}, line 51, column 't': float64 seconds near t=1700000000")
    assert "238 ns apart" in message
    assert "\n" not in message


@pytest.mark.parametrize(("base", "step", "dt"), [(0.0, 1e-7, 1e-7), (1.7e9, 1e-6, 1e-6)])
def test_times_float64_holds_are_read(tmp_path: Path, base: float, step: float, dt: float) -> None:
    """From the log's start at 10 MHz, or at Unix time at 1 MHz: within the tolerance."""
    log = _write(tmp_path / "log.csv", base, step)
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=dt)
    signals = load_signals(log, spec, ReadOptions())
    assert signals.n_samples == 50
    assert signals.unmeasured_outputs is None
