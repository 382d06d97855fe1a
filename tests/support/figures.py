"""The figures hybridlog's plots save, kept for a test to read (drawn, so text has its place)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest


def drawn_figures(monkeypatch: pytest.MonkeyPatch, draw: Callable[[], object]) -> dict[str, Any]:
    """The figures ``draw()`` saves through :func:`hybridlog.report.plots._save`, by file name.

    Each is drawn before it is saved, so that its text and layout are where the PNG has them.
    """
    from hybridlog.report import plots

    figures: dict[str, Any] = {}
    save = plots._save

    def keep_then_save(fig: Any, path: Path) -> Path:
        fig.canvas.draw()
        figures[path.name] = fig
        return save(fig, path)

    monkeypatch.setattr(plots, "_save", keep_then_save)
    draw()
    return figures
