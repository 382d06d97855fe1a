r"""Which characters the figures' font can draw, and an escape for those it cannot.

matplotlib draws a character that none of its fonts holds as an empty box ("tofu"): the
mode ids ``閉じた`` and ``開いた`` were two rows of three identical boxes in ``modes.png``,
and a component named ``水槽`` an unreadable y label.  The figures' text goes through
:func:`hybridlog.report.plot_data.plain_text`, which writes such characters as Python
escapes (``\u9589``), so that every label stays readable and two different ids never look
the same.  Imported only for text that is not ASCII or holds what reads as such an escape,
when a figure is drawn: it loads matplotlib's font manager.
"""

from __future__ import annotations

import functools

from matplotlib import font_manager
from matplotlib.font_manager import FontProperties
from matplotlib.ft2font import FT2Font

__all__ = ["drawable", "escape_undrawable"]


@functools.cache
def _fonts() -> tuple[FT2Font, ...]:
    """The fonts matplotlib draws the figures' text with (the default family and its fallbacks).

    ``_find_fonts_by_props`` is the list matplotlib's Agg renderer itself falls back
    through (matplotlib >= 3.6); without it, the one font ``findfont`` names.
    """
    properties = FontProperties()
    find_all = getattr(font_manager.fontManager, "_find_fonts_by_props", None)
    paths = find_all(properties) if find_all is not None else [font_manager.findfont(properties)]
    return tuple(FT2Font(str(path)) for path in paths)


@functools.cache
def drawable(character: str) -> bool:
    """Whether one of the figures' fonts has a glyph for ``character``."""
    code = ord(character)
    return any(font.get_char_index(code) != 0 for font in _fonts())


def escape_undrawable(text: str) -> str:
    r"""``text`` with each character the figures' fonts cannot draw as its escape (``\u9589``).

    Characters beyond the Basic Multilingual Plane are written ``\U0001f600``-style, as Python
    writes them.  Where an escape is written, or the text holds what reads as one (``\u`` or
    ``\U``), each of its backslashes is written twice, as Python does: the mode ids ``閉`` and
    ``\u9589`` (six ASCII characters) were drawn alike, as ``\u9589``; now the second is
    ``\\u9589``.  Any other text is returned as it is (ASCII is always drawn: the fonts hold
    it).
    """
    if not _looks_escaped(text) and all(c.isascii() or drawable(c) for c in text):
        return text
    return "".join(
        "\\\\" if c == "\\" else c if c.isascii() or drawable(c) else _escape(c) for c in text
    )


def _looks_escaped(text: str) -> bool:
    r"""Whether ``text`` holds ``\u`` or ``\U``, as each escape of :func:`escape_undrawable`."""
    return "\\u" in text or "\\U" in text


def _escape(character: str) -> str:
    code = ord(character)
    return f"\\u{code:04x}" if code <= 0xFFFF else f"\\U{code:08x}"
