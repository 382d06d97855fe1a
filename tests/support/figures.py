"""The figures hybridlog's plots save, kept for a test to read (drawn, so text has its place)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

SAVING_MODULES = ("hybridlog.report.plots", "hybridlog.report.mode_plots")
"""The modules whose figures are saved through :func:`hybridlog.report.plot_figures.save`,
each looking the name up in its own namespace: ``outputs.png`` and ``states.png``,
``modes.png``."""


def patch_save(monkeypatch: pytest.MonkeyPatch, replacement: Callable[[Any, Path], Path]) -> None:
    """Save every figure of a run's plots through ``replacement``, wherever it is drawn."""
    import importlib

    for name in SAVING_MODULES:
        monkeypatch.setattr(importlib.import_module(name), "save", replacement)


def drawn_figures(monkeypatch: pytest.MonkeyPatch, draw: Callable[[], object]) -> dict[str, Any]:
    """The figures ``draw()`` saves through :func:`hybridlog.report.plot_figures.save`, by name.

    Each is drawn before it is saved, so that its text and layout are where the PNG has them.
    """
    from hybridlog.report import plot_figures

    figures: dict[str, Any] = {}
    save = plot_figures.save

    def keep_then_save(fig: Any, path: Path) -> Path:
        fig.canvas.draw()
        figures[path.name] = fig
        return save(fig, path)

    patch_save(monkeypatch, keep_then_save)
    draw()
    return figures
