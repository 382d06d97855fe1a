"""The error family's helpers (``hybridlog.errors``)."""

from pathlib import Path

import pytest

from hybridlog.errors import (
    DataShortError,
    DivergenceError,
    HybridlogError,
    LogError,
    ModelError,
    prefixed,
)
from hybridlog.io.mcap_reader import UnfinishedLogError


@pytest.mark.parametrize(
    ("error", "kind"),
    [
        (ModelError("m.toml: noise: singular"), ModelError),
        (DivergenceError("imm diverged at t = 3 s"), DivergenceError),
        (DataShortError("lags: 2 samples"), DataShortError),
        # a subclass elsewhere whose constructor needs more than the message: rebuilding it
        # with the message alone was "unexpected TypeError" in compare
        (
            UnfinishedLogError("a.mcap: no footer", file=Path("a.mcap"), finding="x", readable=3),
            LogError,
        ),
    ],
)
def test_prefixed_keeps_the_kind_and_the_message(error: HybridlogError, kind: type) -> None:
    copy = prefixed(error, "--estimators imm: ")
    assert type(copy) is kind
    assert str(copy) == f"--estimators imm: {error}"
