"""Fields inside Parquet struct, list and array columns, named as message paths (SPEC §5).

A table exported by pandas, polars or pyarrow may hold a whole vector or record per row: a
column ``q`` of type ``list[f64]`` (three joint angles per row) or ``pose`` of type
``struct{x, y}``.  Their numbers are named the way a message path names them in a bag:
``q[1]`` (``q[-1]`` the last), ``pose.x``, ``wheels[0].speed``; the PlotJuggler spelling
``pose/x`` is accepted too.  A column whose name is the whole text (a flat column literally
called ``pose.x``) is that column.

What a cell holds:

- an empty cell (null) of the column is no sample of any field in it at that row, as an
  empty cell of a flat column is;
- a null field of a non-empty struct is no sample of that field (a struct groups columns);
- an element is read by its index only if every non-empty list on the way has one length in
  every row: in a list that grows or shrinks (the joints of a changing set of joints) ``q[1]``
  would be one signal in one row and another in the next, so it is refused naming the row;
- a null element inside a list (or a null list inside a non-empty cell) is refused naming
  the row: the vector of that row has no value where one is needed.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from hybridlog.errors import excerpt
from hybridlog.io.message_paths import PathError, Step, format_steps, spell_field, split_path
from hybridlog.io.source import FieldError, closest_names
from hybridlog.polars_import import pl

STRUCT, ARRAY, LIST = "struct", "array", "list"


@dataclass(frozen=True)
class ColumnPath:
    """A numeric or text field of a table: a flat column, or a leaf inside a nested one.

    Attributes
    ----------
    text:
        The field's name, e.g. ``q[1]`` or ``pose.x`` (a flat column's name).
    column:
        The table column holding it.
    steps:
        Field names and indices inside the column (empty for a flat column).
    kinds:
        What each step enters: ``"struct"``, ``"array"`` (fixed size) or ``"list"``.
    dtype:
        The leaf's type.
    """

    text: str
    column: str
    steps: tuple[Step, ...]
    kinds: tuple[str, ...]
    dtype: pl.DataType

    @property
    def nested(self) -> bool:
        """Whether the field is inside a nested column (not a flat column)."""
        return bool(self.steps)

    @property
    def in_list(self) -> bool:
        """Whether the leaf is an element of a list or array (where a null is refused)."""
        return any(kind != STRUCT for kind in self.kinds)

    def expr(self, depth: int | None = None) -> pl.Expr:
        """The leaf (or what the first ``depth`` steps reach) as a polars expression."""
        expr = pl.col(self.column)
        for step, kind in list(zip(self.steps, self.kinds, strict=True))[:depth]:
            if kind == STRUCT:
                expr = expr.struct.field(str(step))
            elif kind == ARRAY:
                expr = expr.arr.get(int(step))
            else:
                expr = expr.list.get(int(step), null_on_oob=True)
        return expr

    def lists(self) -> list[tuple[str, pl.Expr, int]]:
        """Every variable-length list on the way: ``(its name, expression, index taken)``."""
        return [
            (self.column + format_steps(self.steps[:depth]), self.expr(depth), int(step))
            for depth, (step, kind) in enumerate(zip(self.steps, self.kinds, strict=True))
            if kind == LIST
        ]


def is_nested(dtype: Any) -> bool:
    """Whether a column of ``dtype`` holds structs, lists or fixed-size arrays."""
    return isinstance(dtype, pl.Struct | pl.List | pl.Array)


def _kind_name(dtype: pl.DataType) -> str:
    if isinstance(dtype, pl.Struct):
        return f"a struct (fields {', '.join(repr(f.name) for f in dtype.fields)})"
    if isinstance(dtype, pl.Array):
        return f"an array of {dtype.size} {_type_name(dtype.inner)}"
    if isinstance(dtype, pl.List):
        return f"a list of {_type_name(dtype.inner)}"
    return f"a {_type_name(dtype)}"


def _type_name(dtype: Any) -> str:
    text = str(dtype)
    return text.lower() if text.isalnum() else text


def field_names(column: str, dtype: pl.DataType) -> list[str]:
    """The fields of a column as :meth:`TableSource.fields` lists them (no data read).

    A flat column is its name; a struct's fields are ``pose.x``; a list or array is
    ``q[]`` (``[]`` takes an index, as in a bag's fields), and the fields of its elements
    ``wheels[].speed``.
    """
    out: list[str] = []

    def walk(prefix: str, node: Any) -> None:
        if isinstance(node, pl.Struct):
            for member in node.fields:
                walk(f"{prefix}.{spell_field(member.name)}", member.dtype)
        elif isinstance(node, pl.List | pl.Array):
            inner = node.inner
            if is_nested(inner):
                walk(f"{prefix}[]", inner)
            else:
                out.append(f"{prefix}[]")
        else:
            out.append(prefix)

    walk(column, dtype)
    return out


def resolve(text: str, schema: Mapping[str, pl.DataType], fields: list[str]) -> ColumnPath:
    """The field ``text`` names in a table of ``schema``.

    Parameters
    ----------
    text:
        A column name, or a column followed by ``.field``, ``/field`` and ``[index]`` steps.
    schema:
        The table's columns and types.
    fields:
        The table's fields (:func:`field_names`), for the closest names.

    Raises
    ------
    PathError
        For a name that starts with no column (listing the closest fields), a step that does
        not fit the column's type (a field a struct lacks, an index into a struct, an index
        outside a fixed-size array), or a path that ends at a struct or list.
    """
    steps: tuple[Step, ...] = ()
    if text in schema:
        column = text
    else:
        starts = [
            c for c in schema if text.startswith(c) and len(text) > len(c) and text[len(c)] in ".[/"
        ]
        if not starts:
            raise PathError(f"no column {excerpt(text)}; {closest_names([text], fields)}")
        column = max(starts, key=len)
        steps = split_path(text, [column]).steps
    dtype: Any = schema[column]
    where = column
    kinds: list[str] = []
    for step in steps:
        if isinstance(dtype, pl.Struct):
            members = {f.name: f.dtype for f in dtype.fields}
            if isinstance(step, int):
                raise PathError(
                    f"{excerpt(where)} is {_kind_name(dtype)}, not a list; name a field"
                )
            if step not in members:
                found = closest_names([step], [spell_field(m) for m in members])
                raise PathError(
                    f"{excerpt(where)} has no field {excerpt(step)}; "
                    f"{found.replace('available', 'fields')}"
                )
            kinds.append(STRUCT)
            dtype = members[step]
        elif isinstance(dtype, pl.List | pl.Array):
            if not isinstance(step, int):
                hint = f"[{step}]" if step.removeprefix("-").isdigit() else f"[0].{step}"
                raise PathError(
                    f"{excerpt(where)} is {_kind_name(dtype)}; index it, e.g. {where}{hint}"
                )
            if isinstance(dtype, pl.Array):
                if not -dtype.size <= step < dtype.size:
                    raise PathError(
                        f"{excerpt(where + format_steps([step]))}: index out of range (the "
                        f"arrays of {excerpt(where)} hold {dtype.size} elements)"
                    )
                kinds.append(ARRAY)
            else:
                kinds.append(LIST)
            dtype = dtype.inner
        else:
            raise PathError(
                f"{excerpt(where)} is {_kind_name(dtype)}; it has no {format_steps([step])}"
            )
        where += format_steps([step])
    if isinstance(dtype, pl.Struct):
        example = f"{where}.{spell_field(dtype.fields[0].name)}" if dtype.fields else where
        raise PathError(f"{excerpt(where)} is {_kind_name(dtype)}; name a field, e.g. {example}")
    if isinstance(dtype, pl.List | pl.Array):
        raise PathError(f"{excerpt(where)} is {_kind_name(dtype)}; add an index, e.g. {where}[0]")
    return ColumnPath(text, column, tuple(steps), tuple(kinds), dtype)


def leaf_values(frame: pl.DataFrame, path: ColumnPath, where: str, row_label: Any) -> pl.Series:
    """The values of ``path`` in the rows of ``frame`` (which holds its column), checked.

    Parameters
    ----------
    frame:
        Rows of the table in file order (at least ``path.column``).
    path:
        The field.
    where:
        The file, prefixing errors.
    row_label:
        ``row_label(i)`` names row ``i`` of ``frame`` in messages (``"row 3"``).

    Returns
    -------
    polars.Series
        Named ``path.text``: null where the row has no sample of the field.

    Raises
    ------
    PathError
        Naming the file, row and column of a list whose length differs from the other
        rows', or a null inside a list.
    FieldError
        For an index beyond the lists' one length (named as the mapping names a field).
    """
    if not path.nested:
        return frame.get_column(path.column).alias(path.text)
    for name, expr, index in path.lists():
        lengths = frame.select(expr.list.len()).to_series()
        known = lengths.drop_nulls()
        if known.len() == 0:
            continue
        first = int(known[0])
        odd = (lengths != first).fill_null(False).to_numpy()
        if odd.any():
            row = int(np.argmax(odd))
            first_row = int(np.argmax(lengths.is_not_null().to_numpy()))
            raise PathError(
                f"{where}, {row_label(row)}, column {excerpt(path.column)}: {excerpt(name)} "
                f"holds {int(lengths[row])} elements, but {first} in {row_label(first_row)}; "
                f"{path.text} needs lists of one length in every row (the same index, the same "
                "signal)"
            )
        if not -first <= index < first:
            raise FieldError(
                where,
                path.text,
                f"index out of range (the lists of {excerpt(name)} hold {first} elements)",
            )
    values = frame.select(path.expr().alias(path.text)).to_series()
    if path.in_list:
        cell = frame.get_column(path.column).is_not_null()
        hole = (values.is_null() & cell).to_numpy()
        if hole.any():
            row = int(np.argmax(hole))
            raise PathError(
                f"{where}, {row_label(row)}, column {excerpt(path.column)}: {excerpt(path.text)} "
                "is null inside the row's list (a row without a sample leaves the whole cell "
                "empty)"
            )
    return values


def expand(frame: pl.DataFrame, column: str) -> tuple[list[ColumnPath], list[str]]:
    """Every leaf of a nested column, its lists' lengths taken from ``frame``; and problems.

    A list whose rows differ in length is one field ``q[]`` (its elements cannot be read
    by index), with a problem naming a row that differs; so is a list or array without an
    element in any row (every list empty, or null), so that the column is still listed.
    """
    schema = {column: frame.schema[column]}
    leaves: list[ColumnPath] = []
    problems: list[str] = []

    def walk(
        text: str, steps: tuple[Step, ...], kinds: tuple[str, ...], dtype: Any, expr: pl.Expr
    ) -> None:
        if isinstance(dtype, pl.Struct):
            for member in dtype.fields:
                walk(
                    f"{text}.{spell_field(member.name)}",
                    (*steps, member.name),
                    (*kinds, STRUCT),
                    member.dtype,
                    expr.struct.field(member.name),
                )
            return
        if not isinstance(dtype, pl.List | pl.Array):
            leaves.append(ColumnPath(text, column, steps, kinds, dtype))
            return
        if isinstance(dtype, pl.Array):
            size, kind = dtype.size, ARRAY
        else:
            lengths = frame.select(expr.list.len()).to_series().drop_nulls().unique()
            if lengths.len() > 1:
                problems.append(
                    f"column {excerpt(column)}: the lists of {excerpt(text)} hold "
                    f"{lengths.min()!s} to {lengths.max()!s} elements (analyze reads "
                    "an element by its index only from lists of one length)"
                )
                leaves.append(ColumnPath(f"{text}[]", column, steps, kinds, dtype))
                return
            size, kind = (int(lengths[0]) if lengths.len() else 0), LIST
        if size == 0:  # no row holds an element (or a list): nothing to index, but the column
            leaves.append(ColumnPath(f"{text}[]", column, steps, kinds, dtype))
            return
        for index in range(size):
            step_expr = (
                expr.arr.get(index) if kind == ARRAY else expr.list.get(index, null_on_oob=True)
            )
            walk(f"{text}[{index}]", (*steps, index), (*kinds, kind), dtype.inner, step_expr)

    walk(column, (), (), schema[column], pl.col(column))
    return leaves, problems
