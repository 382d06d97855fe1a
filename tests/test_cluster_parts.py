"""Regression vectors, k-means baseline, decision rule, labelling and centers.json."""

import json

import numpy as np
import pytest

from hybridlog.cluster.kmeans import kmeans_clustering
from hybridlog.cluster.labels import decide_clusters, label_clusters
from hybridlog.cluster.regressors import RegressorSpec, parse_lags, regression_vectors
from hybridlog.errors import OptionError, OutputError
from hybridlog.jobs.centers import read_centers, write_centers


def test_paper_regression_vectors_and_generalisation():
    y = np.arange(10.0)[:, None]
    u = 100 + np.arange(10.0)[:, None]
    phi = regression_vectors(y, u, RegressorSpec())
    np.testing.assert_array_equal(phi[0], [1.0, 0.0, 100.0])  # [y(k), y(k-1), u(k-1)], k = 1
    assert phi.shape == (9, 3)
    spec = RegressorSpec(output_lags=(1, 0, 3), input_lags=(0, 2))
    y2 = np.stack([np.arange(10.0), -np.arange(10.0)], axis=1)
    u2 = np.stack([u[:, 0], 2 * u[:, 0]], axis=1)
    phi2 = regression_vectors(y2, u2, spec)
    assert phi2.shape == (7, spec.dimension(2, 2))
    assert spec.names(["a", "b"], ["u", "v"])[:3] == ["a(k-1)", "a(k)", "a(k-3)"]
    np.testing.assert_array_equal(phi2[0, :6], [2.0, 3.0, 0.0, -2.0, -3.0, 0.0])
    assert spec.decision_columns(2) == [1, 4]
    assert parse_lags("0, 1,2", "output_lags") == (0, 1, 2) and parse_lags("", "x") == ()
    with pytest.raises(OptionError, match="output_lags: 'a' is not a whole number"):
        parse_lags("0,a", "output_lags")
    with pytest.raises(OptionError, match="input_lags: a lag is listed twice"):
        RegressorSpec(input_lags=(1, 1))
    with pytest.raises(OptionError, match="too few"):
        regression_vectors(y[:2], u[:2], RegressorSpec(output_lags=(0, 3)))


def test_kmeans_finds_separated_blobs_deterministically():
    rng = np.random.default_rng(0)
    data = np.concatenate([rng.normal(0, 0.1, (200, 2)), rng.normal(5, 0.1, (100, 2))])
    first = kmeans_clustering(data, 2, seed=3)
    again = kmeans_clustering(data, 2, seed=3)
    np.testing.assert_array_equal(first.centers, again.centers)
    order = np.argsort(first.centers[:, 0])
    np.testing.assert_allclose(first.centers[order], [[0, 0], [5, 5]], atol=0.05)
    assert sorted(first.sizes.tolist()) == [100, 200]
    with pytest.raises(OptionError, match="fewer than 3 distinct"):
        kmeans_clustering(np.array([[0.0, 0.0]] * 5 + [[1.0, 1.0]] * 5), 3)


def test_decision_rule_is_eq_3():
    decided = decide_clusters(np.array([[-2.0], [0.1], [0.9], [0.0]]), np.array([[-1.0], [1.0]]))
    assert decided.tolist() == [0, 1, 1, 0]  # a tie goes to the first cluster


def test_labelling_by_score_gives_every_mode_a_cluster():
    truth = np.array([1, 0, 1, 1])  # the "right" mode of each cluster

    def score(labels):
        return float(np.sum(labels != truth)) + 0.01 * float(np.sum(labels))

    found = label_clusters(4, ["a", "b"], score, np.array([5, 5, 5, 5]))
    assert found.modes.tolist() == [1, 0, 1, 1]
    assert any("one of 3 clusters" in n for n in found.notes)
    # the best map would use only mode 'b', but every mode must get a cluster
    lazy = label_clusters(2, ["a", "b"], lambda labels: float(labels.sum() == 1), np.array([3, 3]))
    assert sorted(lazy.modes.tolist()) == [0, 1]
    # fewer clusters than modes: one mode stays without a cluster, and the notes say so
    few = label_clusters(1, ["a", "b", "c"], lambda labels: float(labels[0] != 2), np.array([4]))
    assert few.modes.tolist() == [2] and any("'a' has no cluster" in n for n in few.notes)
    # an empty cluster is unused; coordinate descent takes over for large searches
    empty = label_clusters(3, ["a", "b"], lambda labels: 0.0, np.array([2, 0, 2]))
    assert any("decides no sample" in n for n in empty.notes)
    big = label_clusters(13, ["a", "b"], lambda labels: float(labels.sum()), np.ones(13, dtype=int))
    assert "coordinate descent" in big.notes[0]
    assert set(big.modes.tolist()) == {0, 1}


def test_centers_file_round_trip_and_errors(tmp_path):
    path = tmp_path / "c.json"
    content = {
        "regressors": ["y(k)", "y(k-1)"],
        "output_lags": [0, 1],
        "input_lags": [],
        "scaling": {"lower": np.array([-1.0, -1.0]), "upper": [1.0, 1.0]},
        "chiu": {"centers": np.array([[0.5, 0.4], [-0.5, -0.4]]), "modes": ["1", "2"]},
    }
    write_centers(path, content, force=False)
    with pytest.raises(OutputError, match="already exists"):
        write_centers(path, content, force=False)
    stored = read_centers(path)
    assert stored.output_lags == (0, 1) and stored.clusters["chiu"].modes == ("1", "2")
    np.testing.assert_array_equal(stored.clusters["chiu"].centers[1], [-0.5, -0.4])
    data = json.loads(path.read_text())
    for key, value, message in (
        ("format", "x", "format: expected"),
        ("scaling", {"lower": [0.0]}, "scaling.lower: expected a list of 2"),
        ("chiu", {"centers": [[1.0]]}, "chiu.centers: expected a non-empty list of rows of 2"),
        ("chiu", {"centers": [[1.0, 2.0]], "modes": ["1", "2"]}, "chiu.modes: expected 1"),
        ("output_lags", [-1], "output_lags: expected a list"),
    ):
        broken = dict(data, **{key: value})
        path.write_text(json.dumps(broken))
        with pytest.raises(OptionError, match=message):
            read_centers(path)
    path.write_text("{")
    with pytest.raises(OptionError, match="not JSON"):
        read_centers(path)
    with pytest.raises(OptionError, match="no such centers file"):
        read_centers(tmp_path / "missing.json")
