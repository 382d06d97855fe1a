r"""From clusters to modes: the decision rule (paper 001, eqs. (2)–(3)) and cluster labelling.

Decision
    Each sample goes to the cluster whose decision variable is nearest to its output,

    .. math::

        \hat c(k) = \arg\min_i J_i(k), \qquad J_i(k) = \lVert y(k) - y_i^*\rVert^2
        \quad (2),(3)

    where ``y_i*`` are the ``y(k)`` components of centre ``i``.  With several outputs each
    is divided by its unit-box range first (for one output this is exactly eq. (3)).  Ties
    go to the cluster found first: a cluster whose decision values are an earlier one's
    (its twin, :func:`decision_twins`) decides no sample, and takes its twin's mode when
    labelled from the data; labels given by hand (a centres file's, ``cluster_modes``) that
    give twins different modes are refused (:func:`twin_conflict`): which mode their
    samples got would be the order of the centres.
Labelling
    Clusters are numbered in the order the clustering found them, which says nothing about
    the model's modes.  They are labelled from the data and the model alone, never from
    ground truth: a labelling (a map cluster → mode) is scored by a callable, and the map
    with the lowest score wins (the estimators use the switched observer's sum of squared
    one-step output prediction errors, i.e. the labelling under which the model best
    predicts the log).  Every mode must receive at least one cluster when there are at
    least as many clusters as modes (paper 001 assumes the number of modes ``s`` is known and
    every mode occurs; where a lower score would leave a mode without a cluster, as on a log
    in which a mode never occurs, the notes say so); surplus clusters go wherever they fit
    best.  With fewer clusters than modes each cluster gets its own mode.  The search is
    exhaustive up to :data:`EXHAUSTIVE_MAX` maps and :data:`EXHAUSTIVE_WORK_MAX` maps ×
    samples (each map's score runs over the whole log), else coordinate descent (one cluster
    at a time, and the exchange of the modes of a cluster alone in its mode with another
    cluster's, until no change lowers the score) from the best of the round-robin maps.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from hybridlog.cluster.progress import TimedWork, current_reporter, duration_text
from hybridlog.signals import FloatArray, IntArray

__all__ = [
    "DECIDE_BLOCK",
    "EXHAUSTIVE_MAX",
    "EXHAUSTIVE_WORK_MAX",
    "MOST_CLUSTER_NOTES",
    "NO_CLUSTER",
    "ClusterLabels",
    "cluster_notes",
    "decide_clusters",
    "decision_twins",
    "label_clusters",
    "twin_conflict",
]


def decide_clusters(
    outputs: FloatArray, decision_values: FloatArray, scale: FloatArray | None = None
) -> IntArray:
    """Nearest decision variable of every sample (eqs. (2)–(3)).

    The distance is over the outputs measured at the sample: NaN in ``outputs`` (an output
    the log did not measure there, ``AlignedSignals.measured_outputs()``) is left out of it,
    and a sample with none measured is decided by nothing (:data:`NO_CLUSTER`).

    Parameters
    ----------
    outputs:
        ``y(k)``, shape ``(N, n_y)``, NaN where not measured.
    decision_values:
        ``y_i*`` of each cluster, shape ``(c, n_y)``.
    scale:
        Divisor of each output (its unit-box range), shape ``(n_y,)``; default 1.

    Returns
    -------
    IntArray
        Cluster index of each sample, shape ``(N,)``; :data:`NO_CLUSTER` where no output
        was measured.
    """
    y = np.asarray(outputs, dtype=np.float64)
    centres = np.asarray(decision_values, dtype=np.float64)
    divisor = np.ones(y.shape[1]) if scale is None else np.asarray(scale, dtype=np.float64)
    divisor = np.where(divisor > 0.0, divisor, 1.0)
    decided: IntArray = np.empty(y.shape[0], dtype=np.int64)
    rows = max(1, DECIDE_BLOCK // max(1, centres.shape[0]))
    for first in range(0, y.shape[0], rows):
        decided[first : first + rows] = _nearest(y[first : first + rows], centres, divisor)
    decided[np.isnan(y).all(axis=1)] = NO_CLUSTER
    return decided


def _nearest(y: FloatArray, centres: FloatArray, divisor: FloatArray) -> IntArray:
    """The centre of least ``Σ_j ((y_j − y_ij*)/s_j)²`` for every row of ``y`` (NaN: no term).

    The costs as eq. (3) writes them, but where the least of a row's overflowed (a sample
    far outside the centres' range in units of that range: centres fitted on a log of
    amplitude 1e-300, applied to one of amplitude 1, made every cost inf, and the first
    centre won whatever the distances, or analyze stopped "on numerical trouble") or may
    have lost terms to underflow (below :data:`_COST_FLOOR`, an exact hit among them):
    those rows are decided by :func:`_robust_nearest`.
    """
    costs = np.zeros((y.shape[0], centres.shape[0]))
    with np.errstate(over="ignore", under="ignore"):
        for j in range(y.shape[1]):
            term = ((y[:, j, None] - centres[None, :, j]) / divisor[j]) ** 2
            costs += np.where(np.isnan(term), 0.0, term)  # y_j(k) not measured: no term
    nearest: IntArray = np.argmin(costs, axis=1)
    least = costs[np.arange(costs.shape[0]), nearest]
    trusted = (least >= _COST_FLOOR) & (least < np.inf)
    doubtful = ~trusted & ~np.isnan(y).all(axis=1)
    if doubtful.any():
        nearest[doubtful] = _robust_nearest(y[doubtful], centres, divisor)
    return nearest


_COST_FLOOR = float(np.finfo(np.float64).tiny) * 2.0**54
"""A least cost at or above this (4e-292) holds its terms to half an ulp: one that
underflowed is below ``tiny``, 2^-54 of it."""


def _robust_nearest(y: FloatArray, centres: FloatArray, divisor: FloatArray) -> IntArray:
    """:func:`_nearest` for rows whose costs overflow or underflow as eq. (3) writes them.

    Each row's terms ``t_j = |y_j − y_ij*|/s_j`` are divided first by the power of two
    ``2^e`` in ``(m, 2m]``, ``m`` its least largest term (the ∞-norm of its nearest centre in
    that norm): exact, so the costs compare as eq. (3)'s do, the winner's cost lies in
    ``[1/4, n_y)``, and a cost that overflows is a loser's.  Where ``m`` itself overflowed
    the costs are compared as logarithms; where it is 0 a centre is hit exactly and wins.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        t = np.abs(y[:, None, :] - centres[None, :, :])
        t /= divisor
    t[np.isnan(t)] = 0.0  # y_j(k) not measured: no term
    largest = t.max(axis=2)
    m = largest.min(axis=1)
    costs = largest  # m = 0: the hit (largest term 0) wins
    scaled = np.isfinite(m) & (m > 0.0)
    if scaled.any():
        costs[scaled] = _scaled_squares(t[scaled], m[scaled])
    far = np.isinf(m)
    if far.any():
        costs[far] = _log_norms(y[far], centres, divisor)
    nearest: IntArray = np.argmin(costs, axis=1)
    return nearest


def _scaled_squares(t: FloatArray, m: FloatArray) -> FloatArray:
    """``Σ_j (t_j·2^-e)²`` per row and centre, with ``m = f·2^e``, ``f ∈ [0.5, 1)``."""
    _, exponent = np.frexp(m)
    with np.errstate(over="ignore", under="ignore"):
        t = np.ldexp(t, -exponent[:, None, None])
        t *= t
    costs: FloatArray = t.sum(axis=2)
    return costs


def _log_norms(y: FloatArray, centres: FloatArray, divisor: FloatArray) -> FloatArray:
    """``log √Σ_j t_j²`` from ``log t_j = log|y_j − y_ij*| − log s_j``: ``t`` overflowed."""
    with np.errstate(divide="ignore", invalid="ignore"):
        logs = np.log(np.abs(y[:, None, :] - centres[None, :, :])) - np.log(divisor)
    logs[np.isnan(logs)] = -np.inf  # y_j(k) not measured: no term
    top = logs.max(axis=2, keepdims=True)  # finite: every centre has a term that overflowed
    with np.errstate(under="ignore"):
        costs: FloatArray = top[..., 0] + 0.5 * np.log(np.exp(2.0 * (logs - top)).sum(axis=2))
    return costs


def decision_twins(decision_values: FloatArray) -> dict[int, int]:
    """Cluster → the first cluster with the same decision values ``y_i*`` (its twin).

    Eq. (3) cannot tell such clusters apart: every sample of theirs goes to the first, so a
    twin decides no sample whatever its other components (centres of a log whose output
    stayed constant while its input moved).
    """
    values = np.asarray(decision_values, dtype=np.float64) + 0.0  # -0.0 is 0.0
    if values.shape[0] < 2:
        return {}
    _, first, inverse = np.unique(values, axis=0, return_index=True, return_inverse=True)
    twins = first[np.ravel(inverse)]
    return {c: int(t) for c, t in enumerate(twins.tolist()) if t != c}


def twin_conflict(
    modes: IntArray, decision_values: FloatArray, mode_ids: Sequence[str]
) -> str | None:
    """Why labels given by hand cannot be used: twins (:func:`decision_twins`) of other modes.

    ``None`` when every twin has its twin's mode.  A centres file edited to add a copy of a
    centre under another mode, or ``cluster_modes`` giving two clusters of one ``y(k)`` two
    modes, was used as the order of the centres decides: the later one never, unsaid.
    """
    for c, twin in decision_twins(decision_values).items():
        if modes[c] != modes[twin]:
            values = ", ".join(f"{v + 0.0:.6g}" for v in np.asarray(decision_values)[twin])
            return (
                f"clusters {twin + 1} and {c + 1} have the same decision values y* = "
                f"[{values}] but the modes '{mode_ids[modes[twin]]}' and "
                f"'{mode_ids[modes[c]]}': eq. (3) cannot tell them apart, so which mode their "
                "samples get would be the order of the centres; give them one mode"
            )
    return None


NO_CLUSTER = -1
"""What :func:`decide_clusters` gives a sample without a measured output: no decision."""


DECIDE_BLOCK = 1 << 20
"""Sample × cluster costs :func:`decide_clusters` holds at once (8 MiB): one (N, c) table
for the whole log took 190 MB for 5,000 samples and 4,833 clusters, 8 GB for a 10⁶-sample log
and 1,000 k-means centres."""


EXHAUSTIVE_MAX = 4096
"""Largest number of cluster → mode maps searched exhaustively."""


EXHAUSTIVE_WORK_MAX = 1 << 26
"""Largest number of maps × samples searched exhaustively (about 5 s on 2 cores).

Each map's score runs the observer over the whole log (about 0.1 s at 10^6 samples): the
512 maps of 9 clusters took 71 s on the double cart's 10^6 samples (``--radius 0.2``), 12
clusters would take minutes, silently, where coordinate descent found the same labels in
3 s.  On 28 clusterings of 10^3 to 10^6 samples (radius 0.15 to 0.4) descent found the
exhaustive search's labels on every log of 2·10^4 samples or more; only on 10^3 samples
(where the exhaustive search is cheap) did it once stop at a worse map."""


@dataclass(frozen=True)
class ClusterLabels:
    """Mode of every cluster and how it was chosen.

    Attributes
    ----------
    modes:
        Mode index of each cluster, shape ``(c,)``.
    score:
        Score of the chosen map.
    alternatives:
        ``alternatives[c, i]``: the score with cluster ``c`` alone moved to mode ``i``.
    sizes:
        Samples decided for each cluster.
    notes:
        One line per cluster (and per mode without a cluster), for reports.
    undecided:
        The clusters with samples whose mode the score does not decide: another admissible
        map that labels them otherwise scores the same (a log that does not tell the modes
        apart, or errors whose squares leave float64's range); their label is the first
        mode found, a guess that a ``WARNING:`` note names.
    """

    modes: IntArray
    score: float
    alternatives: FloatArray
    sizes: IntArray
    notes: tuple[str, ...]
    undecided: tuple[int, ...] = ()


def _admissible(labels: Sequence[int], n_modes: int, n_clusters: int, sizes: IntArray) -> bool:
    used = {m for c, m in enumerate(labels) if sizes[c] > 0}
    populated = int(np.count_nonzero(sizes))
    if populated >= n_modes:
        return len(used) == n_modes
    return len(used) == populated


def label_clusters(
    n_clusters: int,
    mode_ids: Sequence[str],
    score: Callable[[IntArray], float],
    sizes: IntArray,
    *,
    what: str = "score",
    samples: int | None = None,
    twins: Mapping[int, int] | None = None,
) -> ClusterLabels:
    """Label clusters as modes by the lowest ``score(map)`` (see the module docstring).

    Parameters
    ----------
    n_clusters:
        Number of clusters ``c``.
    mode_ids:
        The model's mode ids.
    score:
        ``score(labels)`` for ``labels`` of shape ``(c,)`` (mode index per cluster); lower
        is better.
    sizes:
        Samples decided for each cluster (clusters without samples are ignored).
    what:
        Name of the score, for the notes.
    samples:
        Samples each ``score`` call runs over, the work of one map (default: the sum of
        ``sizes``).
    twins:
        Cluster → the earlier cluster of the same decision values (:func:`decision_twins`):
        it decides no sample, and gets its twin's mode (any other would give the labels a
        contradiction no score chose; a centres file of them was refused on reading back).
    """
    n_modes = len(mode_ids)
    sizes = np.asarray(sizes, dtype=np.int64)
    samples = int(sizes.sum()) if samples is None else samples
    maps = n_modes**n_clusters
    scores: dict[tuple[int, ...], float] = {}
    best: tuple[int, ...] | None = None
    method, why = "coordinate descent", ""
    if maps <= EXHAUSTIVE_MAX and maps * max(1, samples) <= EXHAUSTIVE_WORK_MAX:
        scores, best = _exhaustive(n_clusters, n_modes, sizes, score)
        method = "exhaustive search"
    elif maps <= EXHAUSTIVE_MAX:  # few maps, but each scored over a long log
        why = (
            f" (not an exhaustive search: {maps:,} maps scored over {samples:,} samples each "
            f"exceed {EXHAUSTIVE_WORK_MAX:,} map-samples)"
        )
    descent = _Descent(n_clusters, n_modes, sizes, score)
    if best is None:
        best = descent.run()
    else:
        descent.start(np.array(best, dtype=np.int64), scores[best])
    chosen = np.array(best, dtype=np.int64)
    for c, twin in (twins or {}).items():  # no sample: the score is the same
        chosen[c] = chosen[twin]
    alternatives = descent.alternatives()
    total = descent.score
    undecided = _undecided(chosen, total, scores, descent, alternatives, sizes)
    notes = (
        f"clusters labelled by {method} over cluster -> mode maps: {what} {total:.4g}{why}",
        *cluster_notes(chosen, sizes, mode_ids, alternatives=alternatives, what=what, twins=twins),
        *_kept_modes(chosen, alternatives, total, sizes, mode_ids, what),
        *_undecided_notes(undecided, chosen, sizes, mode_ids, what, total),
    )
    return ClusterLabels(
        modes=chosen,
        score=total,
        alternatives=alternatives,
        sizes=sizes,
        notes=notes,
        undecided=undecided,
    )


def _undecided(
    chosen: IntArray,
    total: float,
    scores: dict[tuple[int, ...], float],
    descent: _Descent,
    alternatives: FloatArray,
    sizes: IntArray,
) -> tuple[int, ...]:
    """The clusters with samples that another admissible map of the same score labels otherwise.

    After an exhaustive search every map tied with the chosen one counts (a swap of two
    clusters too); after coordinate descent the single moves from it.  The lowest score
    wins, and of equal ones the first found: without this, a log on which every map scores
    the same (a plant at rest, errors whose squares underflow to 0) was labelled by the
    order of the search, and its mode accuracy reported as if the data had chosen.
    """
    populated = sizes > 0
    if not math.isfinite(total):
        return ()
    found: set[int] = set()
    if scores:
        for labels, value in scores.items():
            if value == total:
                differ = (np.array(labels, dtype=np.int64) != chosen) & populated
                found.update(int(c) for c in np.nonzero(differ)[0])
    else:
        for c, m in zip(*np.nonzero(alternatives == total), strict=True):
            if populated[c] and m != chosen[c] and descent.admissible(int(c), int(m)):
                found.add(int(c))
    return tuple(sorted(found))


def _undecided_notes(
    undecided: tuple[int, ...],
    chosen: IntArray,
    sizes: IntArray,
    mode_ids: Sequence[str],
    what: str,
    total: float,
) -> tuple[str, ...]:
    """The warning naming the clusters whose mode the score left to the search's order."""
    if not undecided:
        return ()
    named = "; ".join(
        f"cluster {c + 1} ({sizes[c]:,} sample{'' if sizes[c] == 1 else 's'}) labelled "
        f"'{mode_ids[chosen[c]]}'"
        for c in undecided
    )
    samples = int(sizes[list(undecided)].sum())
    return (
        f"WARNING: the {what} does not decide the mode of {len(undecided):,} of "
        f"{int(np.count_nonzero(sizes > 0)):,} clusters: another labelling of them scores the "
        f"same ({total:.4g}), so their labels are the first found, not chosen by the log "
        f"({named}); the modes of their {samples:,} samples, and the mode metrics over them, "
        "are a guess (the log does not tell the modes apart there; the estimator option "
        "cluster_modes, analyze --set cluster_modes=2,1, sets the labels by hand)",
    )


def _exhaustive(
    n_clusters: int, n_modes: int, sizes: IntArray, score: Callable[[IntArray], float]
) -> tuple[dict[tuple[int, ...], float], tuple[int, ...] | None]:
    """Every admissible map's score, and the lowest's map (the first found of equal scores).

    Timed as :class:`~hybridlog.cluster.progress.TimedWork`: on a machine slower than
    :data:`EXHAUSTIVE_WORK_MAX` assumes, a command's reporter hears how long it will take.
    """
    scores: dict[tuple[int, ...], float] = {}
    best: tuple[int, ...] | None = None
    maps = n_modes**n_clusters
    work = TimedWork(
        maps,
        "cluster -> mode maps scored",
        lambda left, seconds: (
            f"labelling {n_clusters:,} clusters as modes by exhaustive search: about "
            f"{duration_text(seconds)} more on this machine ({left:,} of {maps:,} cluster -> "
            "mode maps left; a larger radius, or fewer k-means clusters, gives fewer clusters)"
        ),
    )
    with work:
        for done, labels in enumerate(itertools.product(range(n_modes), repeat=n_clusters)):
            if _admissible(labels, n_modes, n_clusters, sizes):
                scores[labels] = float(score(np.array(labels, dtype=np.int64)))
                if best is None or scores[labels] < scores[best]:
                    best = labels
                work.reached(done + 1)
    return scores, best


class _Descent:
    """Coordinate descent over cluster → mode maps, one cluster moved at a time.

    Each trial costs one ``score`` call and O(1) bookkeeping: the current map is an array,
    admissibility is kept as per-mode counts of populated clusters, and only the scores of
    single moves from the current map are remembered (forgotten when it changes).  Keying a
    cache by whole maps made each trial O(c) in time and the cache O(c²) in memory: chiu at
    ``radius = 0.01`` on 5,000 samples (4,833 clusters) took 160 s and 1.7 GB to label.
    """

    def __init__(
        self,
        n_clusters: int,
        n_modes: int,
        sizes: IntArray,
        score: Callable[[IntArray], float],
    ) -> None:
        self.n_clusters = n_clusters
        self.n_modes = n_modes
        self.populated = sizes > 0
        self.needed = min(n_modes, int(np.count_nonzero(self.populated)))
        self._score = score
        self.current = np.zeros(n_clusters, dtype=np.int64)
        self.counts = np.zeros(n_modes, dtype=np.int64)
        self.score = math.inf
        self.moves: dict[tuple[int, int], float] = {}

    def start(self, labels: IntArray, value: float | None = None) -> None:
        """Make ``labels`` (scored ``value``, or scored here) the current map."""
        self.current = np.array(labels, dtype=np.int64)
        self.counts = np.bincount(self.current[self.populated], minlength=self.n_modes)
        self.score = float(self._score(self.current.copy())) if value is None else value
        self.moves = {}

    def admissible(self, c: int, m: int) -> bool:
        """Whether the map with cluster ``c`` moved to mode ``m`` is admissible."""
        used = int(np.count_nonzero(self.counts))
        if self.populated[c] and self.current[c] != m:
            used -= int(self.counts[self.current[c]] == 1)
            used += int(self.counts[m] == 0)
        return used == self.needed

    def move_score(self, c: int, m: int) -> float:
        """Score of the current map with cluster ``c`` moved to mode ``m``."""
        if m == self.current[c]:
            return self.score
        if (c, m) not in self.moves:
            trial = self.current.copy()
            trial[c] = m
            self.moves[c, m] = float(self._score(trial))
        return self.moves[c, m]

    def run(self) -> tuple[int, ...]:
        """Descend from the best round-robin map until no single move lowers the score."""
        starts = [np.arange(self.n_clusters) % self.n_modes]
        starts += [(starts[0] + shift) % self.n_modes for shift in range(1, self.n_modes)]
        values = [float(self._score(starts[0].copy()))]  # may load the compiled observer
        started = time.perf_counter()
        values += [float(self._score(start.copy())) for start in starts[1:]]
        self._announce((time.perf_counter() - started) / max(1, len(starts) - 1))
        first = int(np.argmin(values))
        self.start(starts[first], values[first])
        improved = True
        while improved:
            improved = False
            for c in range(self.n_clusters):
                for m in range(self.n_modes):
                    if m == self.current[c] or not self.admissible(c, m):
                        continue
                    value = self.move_score(c, m)
                    if value < self.score:
                        if self.populated[c]:
                            self.counts[self.current[c]] -= 1
                            self.counts[m] += 1
                        self.current[c] = m
                        self.score = value
                        self.moves = {}
                        improved = True
            improved = self._swap() or improved
        return tuple(int(m) for m in self.current)

    def _swap(self) -> bool:
        """Exchange the modes of a cluster alone in its mode and another cluster, if better.

        A cluster that alone gives its mode a cluster cannot move by itself (the map would
        leave that mode without one): with as many clusters as modes (k-means' k) no single
        move was admissible, and the search ended at its round-robin start (6 modes: one-step
        SSE 17.7 where the exhaustive search finds 5.7).  An exchange keeps every mode's
        count.  Only such pinned clusters (at most one per mode) are exchanged, so a pass costs
        at most ``modes × clusters`` scores, as the single moves do.
        """
        pinned = [
            c
            for c in range(self.n_clusters)
            if self.populated[c] and self.counts[self.current[c]] == 1
        ]
        for c in pinned:
            for d in range(self.n_clusters):
                if self.current[d] == self.current[c] or not self.populated[d]:
                    continue
                trial = self.current.copy()
                trial[c], trial[d] = self.current[d], self.current[c]
                value = float(self._score(trial.copy()))
                if value < self.score:
                    self.current = trial
                    self.score = value
                    self.moves = {}
                    return True
        return False

    def _announce(self, per_map: float) -> None:
        """Say how long a pass will take when it is long and a command installed a reporter.

        Each pass scores every cluster in every other mode; the score runs the observer over
        the whole log, so thousands of clusters (a small ``radius``) take minutes, as the
        exact potentials do (:data:`~hybridlog.cluster.subtractive.LONG_WORK_S`).
        """
        reporter = current_reporter()
        if reporter is None:
            return
        from hybridlog.cluster.subtractive import LONG_WORK_S, duration_text

        trials = self.n_clusters * (self.n_modes - 1)
        expected = per_map * trials
        if expected > LONG_WORK_S:
            reporter.note(
                f"labelling {self.n_clusters:,} clusters as modes by coordinate descent: "
                f"each pass scores {trials:,} cluster -> mode maps, about "
                f"{duration_text(expected)} per pass on this machine, until a pass lowers "
                "the score no more (a larger radius, or fewer k-means clusters, gives fewer "
                "clusters)"
            )

    def alternatives(self) -> FloatArray:
        """``[c, i]``: the score with cluster ``c`` alone moved to mode ``i``."""
        table = np.zeros((self.n_clusters, self.n_modes))
        for c in range(self.n_clusters):
            for m in range(self.n_modes):
                table[c, m] = self.move_score(c, m)
        return table


def _kept_modes(
    chosen: IntArray,
    alternatives: FloatArray,
    total: float,
    sizes: IntArray,
    mode_ids: Sequence[str],
    what: str,
) -> list[str]:
    """Notes on the moves that fit better but would leave a mode without a cluster.

    The chosen map admits no better single move but one that empties a mode: on a log where a
    mode never occurs, its cluster would be labelled otherwise, and the notes say so.
    """
    notes: list[str] = []
    populated = sizes > 0
    for c, m in zip(*np.nonzero(alternatives < total), strict=True):
        if np.count_nonzero((chosen == chosen[c]) & populated) != 1:
            continue  # not what kept it: a move of one cluster among several empties no mode
        notes.append(
            f"cluster {c + 1} in mode '{mode_ids[m]}' would give a lower {what} "
            f"({alternatives[c, m]:.4g}) but leave mode '{mode_ids[chosen[c]]}' without a "
            "cluster; kept, as paper 001 assumes that every mode occurs in the log (--set "
            "cluster_modes= sets the labels by hand)"
        )
    return notes


MOST_CLUSTER_NOTES = 100
"""Clusters given a line each in the notes; the rest are counted in one line.  A centres file
of 200,000 clusters wrote a line for each into report.md (11 MB) and report.json (38 MB)."""


def cluster_notes(
    modes: IntArray,
    sizes: IntArray,
    mode_ids: Sequence[str],
    *,
    alternatives: FloatArray | None = None,
    what: str = "score",
    twins: Mapping[int, int] | None = None,
) -> list[str]:
    """One line per cluster (its samples and mode) and per mode that no cluster decides.

    Parameters
    ----------
    modes:
        Mode index of each cluster, shape ``(c,)``.
    sizes:
        Samples decided for each cluster on the log at hand, shape ``(c,)``.
    mode_ids:
        The model's mode ids.
    alternatives:
        ``alternatives[c, i]``: the score with cluster ``c`` alone in mode ``i``, quoted for
        the other modes; ``None`` for labels not chosen by a score (a centres file's).
    what:
        Name of the score.
    twins:
        Cluster → the earlier cluster of the same decision values (:func:`decision_twins`),
        named as why it decides no sample.
    """
    notes: list[str] = []
    for c, chosen in enumerate(modes[:MOST_CLUSTER_NOTES]):
        mode = mode_ids[chosen]
        if sizes[c] == 0:
            twin = (twins or {}).get(c)
            why = (
                ""
                if twin is None
                else f" (its decision values are cluster {twin + 1}'s, which eq. (3) decides)"
            )
            notes.append(f"cluster {c + 1} decides no sample{why}: unused (labelled '{mode}')")
            continue
        others = (
            ""
            if alternatives is None
            else ", ".join(
                f"'{mode_ids[m]}' {alternatives[c, m]:.4g}"
                for m in range(len(mode_ids))
                if m != chosen
            )
        )
        shared = int(np.count_nonzero((modes == chosen) & (sizes > 0)))
        role = "" if shared == 1 else f" (one of {shared} clusters of that mode)"
        alternative = f"; {what} with it in mode {others}" if others else ""
        samples = f"{sizes[c]} sample{'' if sizes[c] == 1 else 's'}"
        notes.append(f"cluster {c + 1} ({samples}) -> mode '{mode}'{role}{alternative}")
    rest = len(modes) - MOST_CLUSTER_NOTES
    if rest > 0:
        unused = int(np.count_nonzero(np.asarray(sizes)[MOST_CLUSTER_NOTES:] == 0))
        notes.append(
            f"clusters {MOST_CLUSTER_NOTES + 1:,} to {len(modes):,}: {rest:,} more, not listed "
            f"({unused:,} of them decide no sample); every cluster's mode is in report.json's "
            "options.classifier.cluster_modes (centers.json: modes)"
        )
    for m, mode in enumerate(mode_ids):
        if not np.any((modes == m) & (sizes > 0)):
            notes.append(f"mode '{mode}' has no cluster: it is never decided")
    return notes
