"""Logs with outputs the alignment bridged, and a bit-for-bit comparison of two results.

An estimator must not read the value the alignment put where the log did not measure an
output (``AlignedSignals.unmeasured_outputs``): changing those values changes nothing.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

from hybridlog.signals import AlignedSignals

TIMINGS = ("runtime_s", "compile_s")
"""Fields of a result that measure the run, not what it computed."""


def with_stand_ins(signals: AlignedSignals, unmeasured: np.ndarray, value: float) -> AlignedSignals:
    """``signals`` with ``unmeasured`` marked and ``value`` written there as the stand-in."""
    outputs = np.where(unmeasured, value, signals.outputs)
    return dataclasses.replace(signals, outputs=outputs, unmeasured_outputs=unmeasured)


def assert_same(a: Any, b: Any, where: str = "result") -> None:
    """``a`` and ``b`` equal bit for bit (NaN where NaN), timings of a result left out."""
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), where
        for field in dataclasses.fields(a):
            if field.name not in TIMINGS:
                assert_same(getattr(a, field.name), getattr(b, field.name), f"{where}.{field.name}")
    elif isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        np.testing.assert_array_equal(a, b, err_msg=where, strict=True)
    elif isinstance(a, Mapping):
        assert isinstance(b, Mapping) and list(a) == list(b), where
        for key in a:
            assert_same(a[key], b[key], f"{where}[{key!r}]")
    elif isinstance(a, list | tuple):
        assert type(a) is type(b) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same(x, y, f"{where}[{i}]")
    elif isinstance(a, float) and np.isnan(a):
        assert isinstance(b, float) and np.isnan(b), where
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"
