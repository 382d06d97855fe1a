"""Clustering at scale: many clusters and long logs keep labelling and deciding linear in memory.

chiu at ``radius = 0.01`` on 5,000 samples found 4,833 clusters; labelling them took 160 s and
1.7 GB (a cache keyed by whole cluster → mode maps, O(c) per trial, O(c²) in memory), and the
decision rule held an (N, c) table of costs (190 MB there, 8 GB for 10⁶ samples and 1,000
centres).
"""

import tracemalloc

import numpy as np
import pytest

from hybridlog.cluster import labels
from hybridlog.cluster.labels import decide_clusters, label_clusters


def _peak_bytes(call):  # type: ignore[no-untyped-def]
    tracemalloc.start()
    try:
        result = call()
        return result, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_labelling_thousands_of_clusters_keeps_no_map_per_trial():
    n = 2_000
    found, peak = _peak_bytes(
        lambda: label_clusters(n, ["a", "b"], lambda m: float(m.sum()), np.ones(n, dtype=np.int64))
    )
    # the lowest admissible map: every cluster in 'a' but one, which keeps 'b' a cluster
    assert int(found.modes.sum()) == 1 and found.score == 1.0
    assert found.notes[0].startswith("clusters labelled by coordinate descent")
    assert peak < 16 * 2**20, f"{peak / 2**20:.0f} MiB"


def test_labelling_by_descent_matches_the_exhaustive_search():
    rng = np.random.default_rng(3)
    weights = rng.normal(size=(6, 3))

    def score(m):  # type: ignore[no-untyped-def]
        return float(weights[np.arange(6), m].sum())

    sizes = np.array([3, 0, 2, 5, 1, 4])
    exhaustive = label_clusters(6, ["a", "b", "c"], score, sizes)
    assert exhaustive.notes[0].startswith("clusters labelled by exhaustive search")
    moved = exhaustive.alternatives
    for c in range(6):
        for m in range(3):
            trial = exhaustive.modes.copy()
            trial[c] = m
            assert moved[c, m] == score(trial)


def test_deciding_a_long_log_holds_no_sample_by_cluster_table():
    rng = np.random.default_rng(0)
    outputs = rng.normal(size=(20_000, 1))
    centres = rng.normal(size=(2_000, 1))
    decided, peak = _peak_bytes(lambda: decide_clusters(outputs, centres))
    assert peak < 64 * 2**20, f"{peak / 2**20:.0f} MiB"  # the whole table: 320 MB
    head = np.argmin((outputs[:500] - centres[:, 0]) ** 2, axis=1)
    assert np.array_equal(decided[:500], head)


@pytest.mark.parametrize("block", [1, 7, 1 << 20])
def test_deciding_in_blocks_gives_every_sample_its_nearest_first_centre(monkeypatch, block):
    monkeypatch.setattr(labels, "DECIDE_BLOCK", block)
    outputs = np.array([[0.0, 1.0], [2.0, 2.0], [1.0, 1.5], [-3.0, 0.0], [1.0, 1.0]])
    centres = np.array([[1.0, 1.0], [0.0, 1.0], [1.0, 1.0], [2.0, 2.0]])  # 1 and 3 tie
    decided = decide_clusters(outputs, centres, np.array([2.0, 1.0]))
    assert decided.tolist() == [1, 3, 0, 1, 0]


def test_a_file_of_one_centre_says_one_centre():
    # the notes said "chiu: 1 centres loaded from one.json"
    from hybridlog.cluster.centers_file import centers_json, parse_centers
    from hybridlog.cluster.classifier import stored_classifier
    from hybridlog.cluster.regressors import RegressorSpec

    content = {
        "mode_ids": ["a", "b"],
        "regressors": ["y(k)"],
        "output_lags": [0],
        "input_lags": [],
        "scaling": {"lower": [0.0], "upper": [1.0]},
        "chiu": {"centers": [[0.5]], "modes": ["a"]},
    }
    stored = parse_centers(centers_json(content), "one.json")
    found = stored_classifier(
        stored,
        "chiu",
        RegressorSpec(output_lags=(0,), input_lags=()),
        np.array([[0.2], [0.7]]),
        names=["y(k)"],
        mode_ids=["a", "b"],
        source="one.json",
    )
    assert found.notes == ("chiu: 1 centre loaded from one.json",)
    assert "mode 'b' has no cluster: it is never decided" in found.labelling


@pytest.mark.parametrize("clusters", [13, 12])
def test_long_labelling_says_how_long_a_pass_takes(monkeypatch, clusters):
    # 14,688 clusters of a 20,000-sample log at radius = 0.01 were labelled for a minute
    # without a word; a command's reporter now hears how long a pass takes, as it does for
    # the exact potentials (LONG_WORK_S is 0 here: any pass is long)
    from contextlib import nullcontext

    from hybridlog.cluster import subtractive
    from hybridlog.cluster.progress import WorkReporter, reporting

    monkeypatch.setattr(subtractive, "LONG_WORK_S", 0.0)
    said: list[str] = []
    reporter = WorkReporter(note=said.append, bar=lambda total, label: nullcontext(len))
    sizes = np.ones(clusters, dtype=np.int64)
    with reporting(reporter):
        found = label_clusters(clusters, ["a", "b"], lambda m: float(m.sum()), sizes)
    assert int(found.modes.sum()) == 1
    if clusters == 12:  # 2^12 maps: searched exhaustively, nothing to announce
        assert said == []
    else:
        assert len(said) == 1, said
        assert said[0].startswith("labelling 13 clusters as modes by coordinate descent: ")
        assert "each pass scores 13 cluster -> mode maps, about " in said[0]


def test_labels_set_by_hand_say_what_each_cluster_decides(tmp_path):
    # cluster_modes=1,1,1 on the double cart: the report said only "labels given by
    # cluster_modes=1,1,1", not that mode '2' is never decided, nor the clusters' samples
    import json

    from click.testing import CliRunner

    from hybridlog.cli import cli
    from tests.support.paths import SAMPLE_LOGS

    out = tmp_path / "r"
    args = ["analyze", str(SAMPLE_LOGS / "double_cart_case1.csv")]
    args += ["--model", "double_cart_case1", "--estimator", "chiu", "--out", str(out)]
    args += ["--set", "cluster_modes=1,1,1", "--quiet"]
    result = CliRunner().invoke(cli, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    notes = json.loads((out / "report.json").read_text())["notes"]
    at = notes.index("labels given by cluster_modes=1,1,1")
    assert notes[at + 1].startswith("cluster 1 (") and "-> mode '1'" in notes[at + 1]
    assert "mode '2' has no cluster: it is never decided" in notes


def test_few_maps_each_over_a_long_log_are_not_searched_exhaustively():
    # 9 clusters of the double cart's 10^6 samples (--radius 0.2): the 512 maps were each
    # scored over the whole log, 71 s without a word; descent found the same labels in 3 s
    calls: list[int] = []
    target = np.array([0, 1, 1, 0, 0, 1, 0, 0, 1])

    def score(m):  # type: ignore[no-untyped-def]
        calls.append(1)
        return float(np.count_nonzero(m != target))

    sizes = np.ones(9, dtype=np.int64)
    long = label_clusters(9, ["a", "b"], score, sizes, samples=1_000_000)
    assert long.notes[0].startswith("clusters labelled by coordinate descent over ")
    assert "512 maps scored over 1,000,000 samples each exceed" in long.notes[0]
    assert len(calls) < 100 and long.modes.tolist() == target.tolist()
    calls.clear()
    short = label_clusters(9, ["a", "b"], score, sizes, samples=1_000)
    assert short.notes[0].startswith("clusters labelled by exhaustive search over ")
    assert len(calls) >= 510 and np.array_equal(short.modes, long.modes)


def test_a_long_exhaustive_search_says_how_long_it_takes(monkeypatch):
    # on a machine slower than EXHAUSTIVE_WORK_MAX assumes, the search times itself
    from contextlib import nullcontext

    from hybridlog.cluster import progress
    from hybridlog.cluster.progress import WorkReporter, reporting

    monkeypatch.setattr(progress, "CALIBRATION_S", 0.0)
    monkeypatch.setattr(progress, "LONG_WORK_S", -1.0)
    said: list[str] = []
    bars: list[tuple[int, str]] = []

    def bar(total, label):  # type: ignore[no-untyped-def]
        bars.append((total, label))
        return nullcontext(lambda done: None)

    with reporting(WorkReporter(note=said.append, bar=bar)):
        label_clusters(6, ["a", "b"], lambda m: float(m.sum()), np.ones(6, dtype=np.int64))
    assert len(said) == 1, said
    assert said[0].startswith("labelling 6 clusters as modes by exhaustive search: about ")
    assert "of 64 cluster -> mode maps left" in said[0]
    assert bars == [(64, "cluster -> mode maps scored")]
