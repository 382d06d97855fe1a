"""The model-file examples of docs/*.md load, as ``hybridlog models FILE`` reads them.

README's commands run in tests/cli/test_readme.py; the pages' ```toml blocks were checked
by nothing but the one complete example of docs/model_files.md. Most of them are fragments
of a model file, so each is loaded in the file it belongs to: the page's complete example, a
built-in model whose table it replaces, or (a fragment that elides with ``"..."``) the
built-in whose text it quotes. A loader that begins refusing what a page shows (a known
component mode without a state's difference equation or an output's equation, a joint mode
checked at load) fails here, naming the page and the block.
"""

import re
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from hybridlog.jobs.model_description import check_and_describe
from hybridlog.model.builtins import builtin_text
from tests.support.paths import ROOT


def toml_blocks() -> list[tuple[str, str]]:
    """Each ```toml block of docs/*.md, with the name of its page."""
    return [
        (page.name, block)
        for page in sorted((ROOT / "docs").glob("*.md"))
        for block in re.findall(r"```toml\n(.*?)```", page.read_text(), flags=re.DOTALL)
    ]


def _is_complete(block: str) -> bool:
    return re.search(r"^dt = ", block, flags=re.MULTILINE) is not None


def _complete_example(block: str) -> str:
    """The page's complete model file (the continuous-time one), with ``block`` after it."""
    (example,) = [
        text for page, text in toml_blocks() if page == "model_files.md" and _is_complete(text)
    ]
    return f"{example}\n{block}"


_COMPONENT_MODEL = """\
dt = 1.0
states = ["x1"]
inputs = ["u1"]
outputs = ["y1"]
commands = ["cmd"]

[initial]
state = [0.0]

"""

_STUCK_OPEN = """
[components.regulator.modes.stuck_open]
equations = ["x1[k] = x1[k-1]", "y1 = x1"]
measurement_noise = {y1 = 0.04}
"""


def _component(block: str) -> str:
    """One component in a model declaring its symbols, with the mode its transition names."""
    return f"{_COMPONENT_MODEL}{block}{_STUCK_OPEN}"


def _bioplex_scenario(block: str) -> str:
    """``bioplex_pgc`` with the fragment as its scenario (its [simulation] tables end the file)."""
    model, header, _ = builtin_text("bioplex_pgc").partition("\n[simulation]\n")
    assert header, "bioplex_pgc has no [simulation] table to replace"
    return f"{model}\n{block}"


def _holds(whole: Any, part: Any) -> bool:
    """Whether every key and value of ``part`` is in ``whole`` (``"..."`` stands for any value)."""
    if part == "...":
        return True
    if isinstance(part, dict):
        return isinstance(whole, dict) and all(
            key in whole and _holds(whole[key], value) for key, value in part.items()
        )
    if isinstance(part, list):
        return (
            isinstance(whole, list)
            and len(whole) == len(part)
            and all(_holds(w, p) for w, p in zip(whole, part, strict=True))
        )
    return bool(whole == part)


def _quoted_from(name: str) -> Callable[[str], str]:
    """The built-in ``name``, once the fragment is found to quote it."""

    def builtin(block: str) -> str:
        text = builtin_text(name)
        assert _holds(tomllib.loads(text), tomllib.loads(block)), f"not {name}'s text"
        return text

    return builtin


_CONTEXTS: dict[str, Callable[[str], str]] = {
    "[signals]": _complete_example,
    "[components.": _component,
    "[simulation]": _bioplex_scenario,
    "booleans = ": _quoted_from("three_tank_valves"),
    "[jumps.": _quoted_from("ice_clutch"),
}
"""The file a fragment belongs to, by the start of its first line."""


def model_text(block: str) -> str:
    """The model file ``block`` is (a complete one) or is part of."""
    if _is_complete(block):
        return block
    first = block.lstrip().splitlines()[0]
    (context,) = [c for start, c in _CONTEXTS.items() if first.startswith(start)] or [None]
    assert context is not None, f"a fragment of no known model file (add it here): {first!r}"
    return context(block)


@pytest.mark.parametrize(
    ("page", "block"),
    toml_blocks(),
    ids=lambda value: value if value.endswith(".md") else value.lstrip().splitlines()[0],
)
def test_the_docs_model_file_examples_load(tmp_path: Path, page: str, block: str) -> None:
    path = tmp_path / "example.toml"
    path.write_text(model_text(block), encoding="utf-8")
    assert check_and_describe(path).startswith(f"{path}: a valid model file"), page


def test_the_docs_pages_show_the_model_file_examples_checked_here() -> None:
    # a page that lost its examples (or a regex that found none) would pass vacuously
    pages = [page for page, _ in toml_blocks()]
    assert pages.count("model_files.md") >= 6
