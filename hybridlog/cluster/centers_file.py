"""``centers.json``: fitted cluster centres and the mode classifier built on them.

Written by ``hybridlog cluster`` and read for the ``chiu`` and ``kmeans`` estimators
(``--set centers=centers.json``).  This module turns the file's text into a
:class:`CentersFile` and content into text; it reads and writes no file (the jobs do:
:mod:`hybridlog.jobs.centers`).  Layout (``format = "hybridlog-centers"``, ``version = 1``)::

    {
      "format": "hybridlog-centers", "version": 1,
      "model": "double_cart_case1", "log": "sample_logs/double_cart_case1.csv",
      "model_key": "3f5c…",                            # the model's content key (below)
      "dt": 0.5,                                       # the model's sample time, seconds
      "mode_ids": ["1", "2"],
      "regressors": ["y(k)", "y(k-1)", "u(k-1)"],
      "output_lags": [0, 1], "input_lags": [1],
      "scaling": {"lower": [...], "upper": [...]},     # the unit hyper-box
      "chiu": {                                        # subtractive clustering
        "parameters": {"radius": 0.5, "squash": 1.25, "accept": 0.5, "reject": 0.15, ...},
        "centers": [[...], ...],                       # data units, one row per cluster
        "modes": ["1", "2"],                           # the classifier: mode of each cluster
        "labelling": ["cluster 1 (...) -> mode '1' ...", ...],
        "potentials": [...], "potential_ratios": [...], "radii": [...], "sigmas": [...], ...
      },
      "kmeans": {"parameters": {...}, "centers": [[...]], "modes": [...], ...},  # optional
      "reading": {"format": "csv", "time": "log", ...}   # what reading the log did
    }

``model_key`` is the content key of the plant the centres were fitted for
(:func:`hybridlog.model.compiled.plant_key`: its equations, parameters, noise and names, not
the input ``[simulation.inputs]`` drove a simulated log with; a file written before holds
:func:`~hybridlog.model.compiled.model_key`, which includes that input, and is accepted too):
the clusters are labelled as modes by how well each mode's equations predict the log, and
the switched observer then runs those equations, so centres of a model whose equations were
edited since (two modes' dynamics swapped) would be used with the wrong labels.  A file
without it (made by hand, or by a hybridlog before it was written) is checked on its name,
modes and regressors alone.  ``dt`` is the model's sample time, the spacing of the samples
in φ(k): a key says only that the model differs, ``dt`` names the commonest edit (a model
copied with another ``dt``), and a file made by hand that records it is checked on it too.

The keys the estimators need are validated on reading, against each other too (labels among
``mode_ids``, centres inside ``scaling``: where a fitted file puts them, ``output_lags`` and
``input_lags`` those the ``regressors`` name, ``decision_values`` the centres' ``y(k)``
components); errors name the file and key.  The rest (``labelling``, ``potentials``,
``notes`` ...) records how the centres were fitted and is not read back, but for the notes
that warn (centres fitted on fewer than 30 regression vectors), which an ``analyze`` by them
repeats.  A key
``hybridlog cluster`` does not write is refused, naming the keys it does: a misspelt
``"moeds"`` left the clusters unlabelled, and the estimator labelled them from the log
instead of by the file's hand-written labels, without a word.
"""

from __future__ import annotations

import difflib
import json
import math
import re
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hybridlog.errors import OptionError, excerpt, printable, shortened
from hybridlog.signals import FloatArray

__all__ = [
    "FORMAT",
    "VERSION",
    "CentersFile",
    "StoredClusters",
    "centers_json",
    "parse_centers",
]

FORMAT = "hybridlog-centers"
VERSION = 1

_KEYS = frozenset(
    {
        *("format", "version", "model", "model_key", "dt", "log", "mode_ids", "regressors"),
        *("output_lags", "input_lags", "scaling", "chiu", "kmeans", "reading"),
        *("mode_accuracy_on_log", "mode_accuracy_over"),
    }
)
"""The top-level keys of a ``centers.json`` (:func:`parse_centers` refuses others)."""

_ENTRY_KEYS = ("parameters", "centers", "decision_values", "modes", "labelling", "notes", "sizes")
_ALGORITHM_KEYS = {
    "chiu": frozenset(
        {
            *_ENTRY_KEYS,
            *("method", "grid", "potentials", "potential_ratios", "radii", "sigmas"),
            "center_rows",
        }
    ),
    "kmeans": frozenset({*_ENTRY_KEYS, "inertia", "seed", "restarts"}),
}
"""The keys of each algorithm's table."""

_PARAMETER_KEYS = {
    "chiu": frozenset({"radius", "squash", "accept", "reject", "self_potential", "method"}),
    "kmeans": frozenset({"clusters", "restarts", "seed"}),
}
"""The clustering options each algorithm's ``parameters`` record."""

_KEY_SHOWN = 40
"""The most characters of an unknown key an error quotes (and matches to a known one)."""

_BOX_SLACK = 1e-9
"""Relative rounding allowed when a centre is checked against the box ``scaling``."""


@dataclass(frozen=True)
class StoredClusters:
    """The centres of one algorithm in a ``centers.json``.

    Attributes
    ----------
    centers:
        Centres in data units, shape ``(c, d)``.
    modes:
        Mode id of each cluster (one of the file's ``mode_ids``), or ``None`` when the file
        has no labels.
    parameters:
        The clustering options the centres were fitted with (``radius``, ``clusters`` ...),
        as ``hybridlog cluster`` recorded them; empty when the file records none (a file
        made by hand).
    """

    centers: FloatArray
    modes: tuple[str, ...] | None
    parameters: Mapping[str, Any] = field(default_factory=dict)
    decision_values: FloatArray | None = None
    """The ``y(k)`` components of the centres as the file records them (``None``: not)."""
    warnings: tuple[str, ...] = ()
    """The file's notes that warn (``WARNING: ...``), as ``hybridlog cluster`` wrote them:
    centres fitted on fewer than 30 regression vectors describe those samples, not the
    plant's modes, and an ``analyze`` deciding by them says so (:func:`_warnings`)."""


@dataclass(frozen=True)
class CentersFile:
    """A validated ``centers.json``."""

    path: str
    model: str
    mode_ids: tuple[str, ...]
    regressors: tuple[str, ...]
    output_lags: tuple[int, ...]
    input_lags: tuple[int, ...]
    lower: FloatArray
    upper: FloatArray
    clusters: dict[str, StoredClusters]
    model_key: str | None = None
    """The content key of the model the centres were fitted for; ``None`` if not recorded."""
    dt: float | None = None
    """The sample time (s) of the model the centres were fitted for; ``None`` if not recorded."""

    def entry(
        self,
        algorithm: str,
        regressors: Sequence[str],
        lags: Mapping[str, tuple[int, ...]],
        mode_ids: Sequence[str],
        source: str,
        origins: Mapping[str, str] | None = None,
    ) -> StoredClusters:
        """The centres of ``algorithm``, checked against a model's modes and regressors.

        ``regressors`` are the names of φ(k) for the model and the options' ``lags``
        (``output_lags``, ``input_lags``); ``source`` names the file in messages, ``origins``
        where a lag option was set (``--set output_lags=0,1,2``, or a model file's key, which
        the message named neither).

        Raises
        ------
        OptionError
            The file's modes are not ``mode_ids``, its regressors are not ``regressors``
            (naming the lags it was fitted with), or it holds no centres of ``algorithm``.
        """
        if set(self.mode_ids) != set(mode_ids):
            raise OptionError(
                f"{source}: mode_ids: the centres were fitted for the modes "
                f"{excerpt(', '.join(self.mode_ids))[1:-1]}, the model has "
                f"{', '.join(mode_ids)}; fit them for this model with hybridlog cluster"
            )
        if self.regressors != tuple(regressors):
            fitted = {"output_lags": self.output_lags, "input_lags": self.input_lags}
            differ = ", ".join(
                f"{key}={_lag_text(value)}" + _given(key, lags.get(key), origins or {})
                for key, value in fitted.items()
                if value != lags.get(key)
            )
            raise OptionError(
                f"{source}: regressors {list(self.regressors)} do not match this "
                f"model and these lags ({list(regressors)})"
                + (f"; the file was fitted with {differ}: set the same" if differ else "")
            )
        if algorithm not in self.clusters:
            raise OptionError(
                f"{source}: {algorithm}: no {algorithm} centres in the file"
                + (" (run hybridlog cluster --compare-kmeans)" if algorithm == "kmeans" else "")
            )
        return self.clusters[algorithm]


def _lag_text(lags: tuple[int, ...] | None) -> str:
    """Lags as an option spells them: ``0,1``; `` (no lag)`` for none."""
    return ",".join(map(str, lags)) if lags else " (no lag)"


def _given(key: str, lags: tuple[int, ...] | None, origins: Mapping[str, str]) -> str:
    """`` (not --set output_lags=0,1,2)``: where the other value of ``key`` was set, if given."""
    origin = origins.get(key, "")
    if not origin:
        return ""
    if origin.startswith("--"):
        return f" (not {origin})"
    text = ",".join(map(str, lags)) if lags else '""'
    return f" (not {origin} = {text})"


def centers_json(content: Mapping[str, Any]) -> str:
    """The text of a ``centers.json`` holding ``content`` (``format`` and ``version`` added)."""
    payload = {"format": FORMAT, "version": VERSION, **content}
    return json.dumps(_plain(payload), indent=2, allow_nan=False) + "\n"


def _plain(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        number = float(value)
        return number if math.isfinite(number) else None
    return value


class _DuplicateKeyError(Exception):
    """A JSON object names a key twice (``json`` keeps the last without a word)."""

    def __init__(self, key: str) -> None:
        super().__init__(key)
        self.key = key


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """The object of ``pairs``; a key named twice raises :class:`_DuplicateKeyError`.

    A second ``"modes"`` added by hand above the first was overridden by it, silently.
    """
    data: dict[str, Any] = {}
    for key, value in pairs:
        if key in data:
            raise _DuplicateKeyError(key)
        data[key] = value
    return data


def parse_centers(text: str, source: str) -> CentersFile:
    """Parse and validate the text of a ``centers.json``.

    Parameters
    ----------
    text:
        The file's content.
    source:
        The file's name, for messages.

    Raises
    ------
    OptionError
        When the text is not JSON, of another format, or a needed key is wrong; the message
        names ``source`` and the key.
    """
    try:  # an editor's byte-order mark (Notepad's UTF-8) is no part of the JSON (RFC 8259 §8.1)
        data = json.loads(text.removeprefix("\ufeff"), object_pairs_hook=_unique_keys)
    except _DuplicateKeyError as err:
        raise OptionError(
            f"{source}: the key {excerpt(err.key)} is given twice in one object; keep one"
        ) from None
    except json.JSONDecodeError as err:
        raise OptionError(f"{source}: not JSON: {err.msg} (line {err.lineno})") from err
    except (ValueError, RecursionError) as err:  # a 5,000-digit integer, 5,000 nested lists
        raise OptionError(f"{source}: not a centres file ({excerpt(str(err), 80)})") from err
    reader = _Reader(source)
    if not isinstance(data, dict):
        raise reader.error("", "expected a JSON object")
    reader.known(data, "", _KEYS)
    if data.get("format") != FORMAT:
        raise reader.error("format", f"expected {FORMAT!r}, got {data.get('format')!r}")
    version = data.get("version")
    if type(version) is not int or version != VERSION:  # not true, not 1.0
        raise reader.error("version", f"unsupported version {version!r}")
    mode_ids = tuple(reader.strings(data, "mode_ids"))
    twice = next((m for i, m in enumerate(mode_ids) if m in mode_ids[:i]), None)
    if twice is not None:  # compared with the model's as a set: ["1", "2", "2"] passed
        raise reader.error("mode_ids", f"the mode {excerpt(twice)} is listed twice")
    regressors = tuple(reader.strings(data, "regressors"))
    d = len(regressors)
    scaling = reader.table(data, "scaling")
    reader.known(scaling, "scaling", {"lower", "upper"})
    lower = reader.vector(scaling, "scaling.lower", d)
    upper = reader.vector(scaling, "scaling.upper", d)
    if np.any(upper < lower):
        raise reader.error("scaling", "every upper bound must be at least the lower one")
    with np.errstate(over="ignore"):
        span = upper - lower
    if not np.all(np.isfinite(span)):
        raise reader.error("scaling", "the range upper - lower must be a finite number")
    clusters: dict[str, StoredClusters] = {}
    for name in ("chiu", "kmeans"):
        if name not in data or data[name] is None:
            continue
        table = reader.table(data, name)
        centers = reader.matrix(table, f"{name}.centers", d)
        reader.inside(centers, lower, span, f"{name}.centers", regressors)
        modes_value = table.get("modes")
        modes = (
            None
            if modes_value is None
            else tuple(reader.strings(table, "modes", f"{name}.modes", length=len(centers)))
        )
        for c, mode in enumerate(modes or ()):
            if mode not in mode_ids:
                raise reader.error(
                    f"{name}.modes",
                    f"cluster {c + 1}'s mode {excerpt(mode)} is not one of mode_ids "
                    f"({excerpt(', '.join(mode_ids))[1:-1]})",
                )
        parameters = (
            {} if table.get("parameters") is None else reader.table(table, f"{name}.parameters")
        )
        reader.known(table, name, _ALGORITHM_KEYS[name])
        reader.known(parameters, f"{name}.parameters", _PARAMETER_KEYS[name])
        decision = (
            None
            if table.get("decision_values") is None
            else reader.matrix(table, f"{name}.decision_values", None, rows=len(centers))
        )
        clusters[name] = StoredClusters(
            centers=centers,
            modes=modes,
            parameters=parameters,
            decision_values=decision,
            warnings=_warnings(table.get("notes")),
        )
    if not clusters:
        raise reader.error("chiu", "the file holds no centres (neither 'chiu' nor 'kmeans')")
    return CentersFile(
        path=source,
        model=str(data.get("model", "")),
        mode_ids=mode_ids,
        regressors=regressors,
        output_lags=reader.lags(data, "output_lags"),
        input_lags=reader.lags(data, "input_lags"),
        lower=lower,
        upper=upper,
        clusters=clusters,
        model_key=reader.key(data, "model_key"),
        dt=reader.positive(data, "dt"),
    )


class _Reader:
    """Typed access to the parsed JSON with errors that name the file and key."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, key: str, what: str) -> OptionError:
        where = f"{self.source}: {key}" if key else self.source
        return OptionError(f"{where}: {what}")

    def table(self, data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
        value = data.get(key.rsplit(".", 1)[-1])
        if not isinstance(value, dict):
            raise self.error(key, "expected a JSON object")
        return value

    def strings(
        self,
        data: Mapping[str, Any],
        name: str,
        key: str | None = None,
        *,
        length: int | None = None,
    ) -> Sequence[str]:
        value = data.get(name)
        key = key or name
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise self.error(key, "expected a list of strings")
        if length is not None and len(value) != length:
            raise self.error(key, f"expected {length} entries, got {len(value)}")
        if not value:
            raise self.error(key, "must not be empty")
        return value

    def key(self, data: Mapping[str, Any], key: str) -> str | None:
        """A content key (64 hexadecimal digits), or ``None`` where the file records none."""
        value = data.get(key)
        if value is None:
            return None
        if not isinstance(value, str) or re.fullmatch(r"[0-9a-f]{64}", value) is None:
            raise self.error(key, "expected 64 hexadecimal digits (the model's content key)")
        return value

    def positive(self, data: Mapping[str, Any], key: str) -> float | None:
        """A finite positive number, or ``None`` where the file records none."""
        value = data.get(key)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(key, "expected a positive number of seconds")
        number = _float(value)
        if not (math.isfinite(number) and number > 0):
            raise self.error(
                key, f"expected a positive number of seconds, got {excerpt(str(value), 40)[1:-1]}"
            )
        return number

    def lags(self, data: Mapping[str, Any], key: str) -> tuple[int, ...]:
        value = data.get(key)
        if not isinstance(value, list) or not all(
            isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in value
        ):
            raise self.error(key, "expected a list of non-negative whole numbers")
        return tuple(value)

    def vector(self, data: Mapping[str, Any], key: str, length: int) -> FloatArray:
        value = data.get(key.rsplit(".", 1)[-1])
        if not isinstance(value, list) or len(value) != length:
            raise self.error(key, f"expected a list of {length} numbers")
        return self._numbers(value, key)

    def matrix(
        self, data: Mapping[str, Any], key: str, columns: int | None, *, rows: int | None = None
    ) -> FloatArray:
        """A list of rows of ``columns`` numbers (``None``: as many as the first row has)."""
        value = data.get(key.rsplit(".", 1)[-1])
        width = "numbers" if columns is None else f"{columns} numbers"
        if columns is None and isinstance(value, list) and value and isinstance(value[0], list):
            columns = len(value[0]) or -1
        if (
            not isinstance(value, list)
            or not value
            or (rows is not None and len(value) != rows)
            or any(not isinstance(row, list) or len(row) != columns for row in value)
        ):
            count = "a non-empty list of" if rows is None else f"a list of {rows}"
            raise self.error(key, f"expected {count} rows of {width}")
        return self._numbers(value, key)

    def known(self, data: Mapping[str, Any], key: str, keys: Collection[str]) -> None:
        """Refuse a key of the object ``data`` (at ``key``) that is not one of ``keys``."""
        for name in data:
            if name not in keys:
                # a key as long as a file (hand-made) is quoted cut, and matched against no
                # key: difflib and the message's whole-line handling copied a 20 MB key
                # about 40 times over
                plain = name.isidentifier() and len(name) <= _KEY_SHOWN
                shown = name if plain else excerpt(name, _KEY_SHOWN)
                close = (
                    difflib.get_close_matches(name, sorted(keys), n=1)
                    if len(name) <= _KEY_SHOWN
                    else []
                )
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise self.error(
                    f"{key}.{shown}" if key else shown,
                    f"not a key of {'a centres file' if not key else repr(key)} "
                    f"({', '.join(sorted(keys))}){hint}",
                )

    def inside(
        self,
        centers: FloatArray,
        lower: FloatArray,
        span: FloatArray,
        key: str,
        regressors: Sequence[str],
    ) -> None:
        """Refuse a centre outside the box ``scaling`` (fitted centres lie in their data's box).

        Subtractive clustering's centres are data points and k-means' centres means of data
        points, so both lie in the box of the data they were fitted on (up to rounding).
        """
        slack = _BOX_SLACK * np.maximum(span, np.maximum(np.abs(lower), np.abs(lower + span)))
        with np.errstate(over="ignore", invalid="ignore"):
            below = centers < lower - slack
            above = centers > lower + span + slack
        outside = np.argwhere(below | above)
        if outside.size:
            c, j = (int(i) for i in outside[0])
            raise self.error(
                key,
                f"centre {c + 1}'s {excerpt(regressors[j])[1:-1]} = {centers[c, j]:.6g} lies "
                f"outside the data's range in scaling [{lower[j]:.6g}, "
                f"{lower[j] + span[j]:.6g}], in which fitted centres lie",
            )

    def _numbers(self, value: list[Any], key: str) -> FloatArray:
        flat = np.asarray(value, dtype=object).ravel()
        if any(isinstance(v, bool) or not isinstance(v, int | float) for v in flat):
            raise self.error(key, "expected numbers")
        array = np.asarray([_float(v) for v in flat], dtype=np.float64).reshape(np.shape(value))
        if not np.all(np.isfinite(array)):
            raise self.error(key, "non-finite number (or one past a float's range, 1.8e308)")
        return array


def _warnings(notes: Any) -> tuple[str, ...]:
    """The notes of a file's ``notes`` list that warn, without their ``WARNING: ``.

    The other notes describe the log the centres were fitted on and are not read back; a
    warning is about the centres themselves (fitted on 2 regression vectors of a 3-row log),
    and ``analyze --set centers=FILE`` said only "2 centres loaded from FILE".

    The file may be written by hand: each warning is repeated on one printable line of at
    most :data:`_WARNING_LIMIT` characters, and the first :data:`_WARNINGS_REPEATED` of them
    only, the others counted (a note of 200,000 characters, or 5,000 warnings, were repeated
    whole into the report's notes and report.md).
    """
    if not isinstance(notes, list):
        return ()
    prefix = "WARNING: "
    found = [
        note.removeprefix(prefix)
        for note in notes
        if isinstance(note, str) and note.startswith(prefix) and note[len(prefix) :].strip()
    ]
    repeated = tuple(
        shortened(printable(" ".join(_ends(note).split())), _WARNING_LIMIT)
        for note in found[:_WARNINGS_REPEATED]
    )
    rest = len(found) - len(repeated)
    more = f"{rest:,} more warning{'s' if rest > 1 else ''} in its notes"
    return (*repeated, more) if rest else repeated


_WARNING_LIMIT = 300
"""The most characters of a file's warning an ``analyze`` repeats (cluster's own: ~220)."""


def _ends(note: str) -> str:
    """``note``, or of a note far longer than a repeated warning its two ends only.

    A warning is repeated cut to :data:`_WARNING_LIMIT` characters; splitting a note of
    40 million words into words first took 30 bytes a character (a centres file of 80 MB
    took 3 GB, and one of 1 GB would take the machine's memory).
    """
    room = 8 * _WARNING_LIMIT
    if len(note) <= 2 * room:
        return note
    return note[:room] + " " + note[len(note) - room :]


_WARNINGS_REPEATED = 3
"""The most warnings of one file's notes an ``analyze`` repeats (cluster writes one)."""


def _float(value: float) -> float:
    """``value`` as a float; a whole number past a float's range is infinite.

    JSON holds whole numbers of any size: ``float(10**400)`` raised OverflowError, which
    ended ``analyze`` as "unexpected OverflowError" naming neither the file nor the key.
    """
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf
