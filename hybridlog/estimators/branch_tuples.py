"""Generated source that binds the values a branch chooses as one tuple.

:func:`bind` (its docstring says why: numba's SSA passes), :func:`select` (one of two
tuples by a condition) and :func:`unpack` (the names after the branches), for the
straight-line backward passes.
"""

from __future__ import annotations

from collections.abc import Sequence

from hybridlog.estimators.unrolled import Entry, Program, term


def select(
    p: Program,
    condition: str,
    bundle: str,
    chosen: Sequence[Entry],
    other: Sequence[Entry],
) -> None:
    """Bind the tuple ``bundle`` to ``chosen`` where ``condition`` holds, else to ``other``."""
    with p.block(f"if {condition}:"):
        bind(p, bundle, chosen)
    with p.block("else:"):
        bind(p, bundle, other)


def bind(p: Program, bundle: str, values: Sequence[Entry]) -> None:
    """``bundle = (values…)``: one tuple where a branch would assign every value's name.

    numba rebuilds SSA form for each variable assigned in more than one place, in a pass
    over every block of the function: a name per value assigned in each branch made that
    pass, not LLVM, most of a straight-line smoother's compile time (expectation
    correction's for three modes: 70 s), where one tuple per branch, unpacked once after
    them (:func:`unpack`), costs one such variable and no run time.

    The tuple is built under a name of its own, assigned once, and then bound to ``bundle``:
    CPython builds a tuple display of more than 30 entries through a list (a step's values
    for 6 states are 6 + 21 + 6 = 33), and numba's rewrite of that list back into a tuple
    refuses a target assigned in more than one place (an ``AssertionError`` compiling the
    pass).
    """
    built = p.fresh(bundle + "_")
    p.emit(f"{built} = ({', '.join(term(value) for value in values)},)")
    p.emit(f"{bundle} = {built}")


def unpack(p: Program, names: Sequence[str], bundle: str) -> None:
    """``names… = bundle`` after the branches that bound it (:func:`bind`)."""
    p.emit(f"{', '.join(names)}, = {bundle}")
