"""Model-file text edits and refusals the model tests share."""

from __future__ import annotations

import pytest

from hybridlog.errors import ModelError
from hybridlog.model.loader import parse_model


def edited(text: str, old: str | tuple[str, ...], new: str | tuple[str, ...]) -> str:
    """``text`` with ``old`` replaced by ``new`` once (or each of a tuple of them, in order);
    each ``old`` must be there, so an edit that misses fails the test instead of testing the
    unedited model."""
    if isinstance(old, tuple):
        assert isinstance(new, tuple)
        for one, other in zip(old, new, strict=True):
            text = edited(text, one, other)
        return text
    assert isinstance(new, str)
    assert old in text, old
    return text.replace(old, new, 1)


def refused(text: str, pattern: str) -> str:
    """The one-line :class:`ModelError` that loading ``text`` as ``m.toml`` raises, matching
    ``m.toml: <pattern>``."""
    with pytest.raises(ModelError, match=r"^m\.toml: " + pattern) as caught:
        parse_model(text, origin="m.toml")
    message = str(caught.value)
    assert "\n" not in message
    return message
