"""Regression vectors, k-means baseline, decision rule, labelling, classifier, centers.json."""

import copy
import dataclasses
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from hybridlog.cluster.centers_file import centers_json, parse_centers
from hybridlog.cluster.classifier import fit_classifier, manual_labels, stored_classifier
from hybridlog.cluster.kmeans import KMeansParameters, kmeans_clustering
from hybridlog.cluster.labels import decide_clusters, decision_twins, label_clusters
from hybridlog.cluster.regressors import RegressorSpec, parse_lags, regression_vectors
from hybridlog.cluster.subtractive import SubtractiveOptions
from hybridlog.errors import OptionError, OutputError
from hybridlog.estimators.chiu import ChiuOptions
from hybridlog.estimators.kmeans import KMeansOptions
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
    for text, item in (("0,,1", 2), ("0,", 2), (",1", 1), (" , ", 1)):  # were skipped
        with pytest.raises(OptionError, match=rf"output_lags: item {item} of .* is empty"):
            parse_lags(text, "output_lags")
    with pytest.raises(OptionError, match="input_lags: a lag is listed twice"):
        RegressorSpec(input_lags=(1, 1))
    with pytest.raises(OptionError, match="too few"):
        regression_vectors(y[:2], u[:2], RegressorSpec(output_lags=(0, 3)))


def test_kmeans_stops_at_its_fixed_point_with_kmeans2s_result(monkeypatch):
    # scipy's kmeans2 runs all 100 iterations: 10 restarts on 10^6 6-D points took minutes.
    # Stopped where the labels repeat, the result is kmeans2's, bit for bit.
    import scipy.cluster.vq as vq

    from hybridlog.cluster.subtractive import unit_box

    rng = np.random.default_rng(8)
    centres = rng.uniform(0, 4, (4, 3))
    data = centres[rng.integers(0, 4, 3000)] + rng.normal(0, 0.6, (3000, 3))
    calls = []
    counted = vq.vq
    monkeypatch.setattr(vq, "vq", lambda *a, **k: calls.append(1) or counted(*a, **k))
    for k in (2, 3, 5):
        found = kmeans_clustering(data, k, restarts=4, seed=k)
        unit = unit_box(data)[0]
        runs = [vq.kmeans2(unit, k, iter=100, minit="++", rng=k + r) for r in range(4)]
        inertia = [((unit - c[lab]) ** 2).sum() for c, lab in runs]
        best = runs[int(np.argmin(inertia))]
        np.testing.assert_array_equal(found.centers_unit, best[0])
        np.testing.assert_array_equal(found.sizes, np.bincount(best[1], minlength=k))
        assert found.inertia == min(inertia)
    # 3 × 4 runs by hybridlog, then the same by kmeans2 itself (100 iterations each)
    assert len(calls) - 12 * 100 < 12 * 40


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


def test_decision_rule_holds_far_outside_the_centres_range_in_float():
    """Centres fitted on a log of amplitude 1e-300, applied to one of amplitude 1e10.

    ((y − y*)/s)² overflowed to inf for every centre: the first won whatever the distances,
    and analyze stopped "chiu stopped on numerical trouble (overflow encountered in square)"
    on a valid centres file.  Costs too small for float lost the exact hit to a tie.
    """
    centres, span = np.array([[0.0], [1e5]]), np.array([1e-300])
    decided = decide_clusters(np.array([[1e10], [-1e10], [3e4], [np.nan]]), centres, span)
    assert decided.tolist() == [1, 0, 0, -1]
    # two outputs, one far off: the other decides, unmeasured (NaN) terms left out
    two = np.array([[0.0, 1e5], [1e5, 0.0]])
    decided = decide_clusters(np.array([[1e10, np.nan], [1e10, 1e10]]), two, np.array([1e-300] * 2))
    assert decided.tolist() == [1, 0]  # the second row: a tie, to the first
    # a sample on a centre 1e-200 from another: the hit wins (both costs underflowed to 0)
    hit = decide_clusters(np.array([[1e-200], [0.0]]), np.array([[0.0], [1e-200]]))
    assert hit.tolist() == [1, 0]


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
    # ... and the notes say which better fit was given up for it (the notes quoted a lower
    # score for the other mode without a word on why it was not taken)
    kept = [n for n in lazy.notes if "would give a lower score (0)" in n]
    assert len(kept) == 2 and all("without a cluster; kept, as paper 001" in n for n in kept)
    assert not any("would give" in n for n in found.notes)
    # fewer clusters than modes: one mode stays without a cluster, and the notes say so
    few = label_clusters(1, ["a", "b", "c"], lambda labels: float(labels[0] != 2), np.array([4]))
    assert few.modes.tolist() == [2] and any("'a' has no cluster" in n for n in few.notes)
    # an empty cluster is unused; coordinate descent takes over for large searches
    empty = label_clusters(3, ["a", "b"], lambda labels: 0.0, np.array([2, 0, 2]))
    assert any("decides no sample" in n for n in empty.notes)
    big = label_clusters(13, ["a", "b"], lambda labels: float(labels.sum()), np.ones(13, dtype=int))
    assert "coordinate descent" in big.notes[0]
    assert set(big.modes.tolist()) == {0, 1}
    # one mode: no other mode to compare with (the note ended in 'SSE with it in mode ')
    single = label_clusters(2, ["only"], lambda labels: 1.0, np.array([3, 2]))
    assert single.notes[1:] == (
        "cluster 1 (3 samples) -> mode 'only' (one of 2 clusters of that mode)",
        "cluster 2 (2 samples) -> mode 'only' (one of 2 clusters of that mode)",
    )


def test_labels_the_score_does_not_decide_are_named_not_passed_off_as_chosen():
    sizes = np.array([5, 5, 0, 4])
    decided = label_clusters(4, ["a", "b"], lambda labels: float(labels[0] != 1), sizes)
    assert decided.modes[0] == 1
    # clusters 2 and 4 may take either mode at score 0 (the empty cluster 3 counts for none)
    assert decided.undecided == (1, 3)
    warning = [n for n in decided.notes if n.startswith("WARNING: ")]
    assert len(warning) == 1 and "mode of 2 of 3 clusters" in warning[0]
    assert "cluster 2 (5 samples) labelled" in warning[0] and "9 samples" in warning[0]
    # every map alike (a log that does not tell the modes apart): every cluster is named
    flat = label_clusters(2, ["a", "b"], lambda labels: 0.0, np.array([3, 3]))
    assert flat.undecided == (0, 1)
    # a swap of two clusters ties with the exhaustive search's choice, no single move does
    swap = label_clusters(2, ["a", "b"], lambda labels: float(labels[0] == labels[1]), sizes[:2])
    assert swap.undecided == (0, 1)
    # coordinate descent: the single moves from the chosen map
    target = np.arange(12) % 2  # clusters 2 to 13 wanted in modes a, b, a, ...; 1 in either
    many = label_clusters(
        13, ["a", "b"], lambda labels: float(np.sum(labels[1:] != target)), np.ones(13, dtype=int)
    )
    assert "coordinate descent" in many.notes[0] and many.undecided == (0,)
    # a score that tells every cluster apart leaves none undecided and warns of nothing
    exact = label_clusters(
        3, ["a", "b"], lambda labels: float(np.sum(labels != [0, 1, 1])), sizes[:3]
    )
    assert exact.undecided == () and not any(n.startswith("WARNING") for n in exact.notes)


def test_centers_file_round_trip_and_errors(tmp_path):
    path = tmp_path / "c.json"
    content = {
        "mode_ids": ["1", "2"],
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
        ("chiu", {"centers": [[1.0, 0.5]], "modes": ["1", "2"]}, "chiu.modes: expected 1"),
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
    # what json itself refuses past its limits was an unexpected ValueError / RecursionError
    for text in ('{"version": 1' + "0" * 4400 + "}", "[" * 5000 + "]" * 5000):
        path.write_text(text)
        with pytest.raises(OptionError, match=r"c\.json: not a centres file"):
            read_centers(path)
    # a pipe blocked the read until a writer came; a device never ends
    os.mkfifo(tmp_path / "pipe.json")
    for special in (tmp_path / "pipe.json", Path("/dev/zero")):
        with pytest.raises(OptionError, match="not a regular file"):
            read_centers(special)


@pytest.mark.parametrize("model", ["ice_clutch", "three_tank_valves", "bioplex_pgc"])
def test_cluster_refuses_a_model_it_cannot_regress_before_reading(model, tmp_path):
    """Continuous-time and components models crashed in the observer design."""
    from hybridlog.errors import ModelError
    from hybridlog.jobs.cluster import discover_modes

    with pytest.raises(ModelError, match=rf"^{model}: hybridlog cluster needs a"):
        discover_modes(tmp_path / "never_read.csv", model, out=tmp_path / "c.json")
    assert list(tmp_path.iterdir()) == []


def _two_blobs():
    rng = np.random.default_rng(3)
    y = np.concatenate([rng.normal(0.0, 0.05, 150), rng.normal(4.0, 0.05, 150)])[:, None]
    u = np.zeros((300, 0))
    return y, u


def test_the_classifier_is_immutable_and_labelling_returns_a_new_one():
    y, u = _two_blobs()
    spec = RegressorSpec(output_lags=(0,), input_lags=())
    fitted = fit_classifier(y, u, spec, SubtractiveOptions(), names=["y(k)"], n_modes=2)
    assert fitted.algorithm == "chiu" and fitted.cluster_modes is None
    assert fitted.details["sizes"].sum() == 300 and len(fitted.centers) == 2
    with pytest.raises(TypeError):
        fitted.details["sizes"] = None  # read-only: no mutation after construction
    with pytest.raises(dataclasses.FrozenInstanceError):
        fitted.cluster_modes = np.array([0, 1])  # type: ignore[misc]
    labelled = fitted.labelled(np.array([1, 0]), ["by hand"], labelling_scores=np.zeros((2, 2)))
    assert labelled.cluster_modes.tolist() == [1, 0] and labelled.labelling == ("by hand",)
    assert list(labelled.details) == [*fitted.details, "labelling_scores"]
    assert fitted.cluster_modes is None and "labelling_scores" not in fitted.details
    km = fit_classifier(y, u, spec, KMeansParameters(seed=1), names=["y(k)"], n_modes=2)
    assert km.algorithm == "kmeans" and list(km.details) == ["inertia", "seed", "restarts", "sizes"]
    np.testing.assert_array_equal(np.sort(km.decide(y)), np.sort(fitted.decide(y)))
    assert manual_labels(" 2, 1", ["1", "2"], 2).tolist() == [1, 0]
    with pytest.raises(OptionError, match=r"cluster_modes: 1 mode ids for 2 clusters \('2'\)"):
        manual_labels("2", ["1", "2"], 2)
    with pytest.raises(OptionError, match=r"cluster_modes: item 2 of '2,,1' is empty"):
        manual_labels("2,,1", ["1", "2"], 2)  # was read as "2,1"


def test_estimator_options_default_to_the_clustering_defaults():
    # The estimators' options declare help and ranges; the clustering they ask for is
    # cluster/'s, with the same defaults (MATLAB subclust; ten k-means++ runs from seed 0).
    assert ChiuOptions().clustering() == SubtractiveOptions()
    assert KMeansOptions().clustering() == KMeansParameters()
    assert ChiuOptions().regressor_spec() == KMeansOptions().regressor_spec() == RegressorSpec()


_STORED = {
    "mode_ids": ["a", "b"],
    "regressors": ["y(k)"],
    "output_lags": [0],
    "input_lags": [],
    "scaling": {"lower": [-0.5], "upper": [4.5]},
    "chiu": {"centers": [[4.0], [0.0]], "modes": ["b", "a"], "labelling": ["why"]},
}


def test_a_stored_classifier_comes_from_parsed_text_not_a_file():
    y, _ = _two_blobs()
    spec = RegressorSpec(output_lags=(0,), input_lags=())
    stored = parse_centers(centers_json(_STORED), "mem.json")
    found = stored_classifier(
        stored, "chiu", spec, y, names=["y(k)"], mode_ids=["a", "b"], source="mem.json"
    )
    assert found.cluster_modes.tolist() == [1, 0]
    assert found.notes == ("chiu: 2 centres loaded from mem.json",)
    assert found.details["sizes"].tolist() == [150, 150]
    # the notes say what each cluster decides on this log, not what the file's notes said
    # of the log the centres were fitted on
    assert found.labelling == (
        "labels loaded from mem.json",
        "cluster 1 (150 samples) -> mode 'b'",
        "cluster 2 (150 samples) -> mode 'a'",
    )
    with pytest.raises(OptionError, match=r"^mem.json: regressors \['y\(k\)'\] do not match"):
        stored_classifier(
            stored, "chiu", spec, y, names=["z(k)"], mode_ids=["a", "b"], source="mem.json"
        )
    # the lags the centres were fitted with, when they are not the ones given
    with pytest.raises(
        OptionError,
        match=r"^mem.json: regressors .* the file was fitted with output_lags=0, input_lags= "
        r"\(no lag\): set the same$",
    ):
        stored_classifier(
            stored,
            "chiu",
            RegressorSpec(),
            y,
            names=["y(k)", "y(k-1)", "u(k-1)"],
            mode_ids=["a", "b"],
            source="mem.json",
        )
    with pytest.raises(
        OptionError, match=r"^mem.json: kmeans: no kmeans centres .*--compare-kmeans"
    ):
        stored_classifier(
            stored, "kmeans", spec, y, names=["y(k)"], mode_ids=["a", "b"], source="mem.json"
        )
    with pytest.raises(OptionError, match=r"^mem.json: not JSON"):
        parse_centers("{", "mem.json")


def test_stored_labels_are_the_models_modes_or_refused():
    """Labels of modes the model lacks were dropped and the clusters relabelled by the fit."""
    y, _ = _two_blobs()
    spec = RegressorSpec(output_lags=(0,), input_lags=())
    stored = parse_centers(centers_json(_STORED), "mem.json")
    with pytest.raises(
        OptionError,
        match=r"^mem.json: mode_ids: the centres were fitted for the modes a, b, the model has "
        r"1, 2; fit them for this model with hybridlog cluster$",
    ):
        stored_classifier(
            stored, "chiu", spec, y, names=["y(k)"], mode_ids=["1", "2"], source="mem.json"
        )
    # a label edited to a mode the file does not list
    edited = dict(_STORED, chiu={"centers": [[4.0], [0.0]], "modes": ["b", "7"]})
    with pytest.raises(
        OptionError, match=r"^mem.json: chiu.modes: cluster 2's mode '7' is not one of mode_ids"
    ):
        parse_centers(centers_json(edited), "mem.json")
    missing = {k: v for k, v in _STORED.items() if k != "mode_ids"}
    with pytest.raises(OptionError, match=r"^mem.json: mode_ids: expected a list of strings$"):
        parse_centers(centers_json(missing), "mem.json")
    # a duplicated centre decides nothing: the notes say so, and which mode is never decided
    # (given another mode it is refused: test_twins_given_other_modes_by_hand_are_refused)
    twice = dict(_STORED, chiu={"centers": [[4.0], [4.0]], "modes": ["b", "b"]})
    found = stored_classifier(
        parse_centers(centers_json(twice), "mem.json"),
        "chiu",
        spec,
        y,
        names=["y(k)"],
        mode_ids=["a", "b"],
        source="mem.json",
    )
    assert found.labelling[1:] == (
        "cluster 1 (300 samples) -> mode 'b'",
        "cluster 2 decides no sample (its decision values are cluster 1's, which eq. (3) "
        "decides): unused (labelled 'b')",
        "mode 'a' has no cluster: it is never decided",
    )


@pytest.mark.parametrize(
    ("edit", "key"),
    [
        (lambda d: d["chiu"]["centers"][0].__setitem__(0, 10**400), "chiu.centers"),
        (lambda d: d["scaling"]["upper"].__setitem__(0, -(10**400)), "scaling.upper"),
        (
            lambda d: d["chiu"].__setitem__("decision_values", [[10**400], [0]]),
            "chiu.decision_values",
        ),
    ],
)
def test_a_whole_number_past_a_floats_range_is_refused_naming_the_key(edit, key):
    """JSON holds whole numbers of any size: float(10**400) ended analyze as 'unexpected
    OverflowError in centers_file.py' naming neither the file nor the key."""
    content = copy.deepcopy(_STORED)
    edit(content)
    with pytest.raises(OptionError, match=rf"^mem.json: {key}: non-finite number \(or one past"):
        parse_centers(centers_json(content), "mem.json")
    with pytest.raises(
        OptionError, match=r"^mem.json: dt: expected a positive number .*, got 1000"
    ):
        parse_centers(centers_json({**_STORED, "dt": 10**400}), "mem.json")


def test_a_centres_file_with_a_byte_order_mark_is_read(tmp_path):
    """Saved by an editor that marks UTF-8 (Notepad): 'not JSON: Unexpected UTF-8 BOM'."""
    path = tmp_path / "centers.json"
    path.write_text(centers_json(_STORED), encoding="utf-8-sig")
    assert read_centers(path).clusters["chiu"].modes == ("b", "a")


def test_a_stored_file_at_odds_with_itself_is_refused_naming_the_key():
    """An edited centre far outside the data's box overflowed ('numerical trouble in ...')."""
    for edit, message in (
        (
            {"chiu": {"centers": [[1e308], [0.0]]}},
            r"chiu.centers: centre 1's y\(k\) = 1e\+308 lies outside the data's range in "
            r"scaling \[-0.5, 4.5\]",
        ),
        ({"scaling": {"lower": [-1e308], "upper": [1e308]}}, r"scaling: the range upper - lower"),
        ({"version": True}, r"version: unsupported version True"),
        ({"version": 1.0}, r"version: unsupported version 1.0"),
    ):
        with pytest.raises(OptionError, match=rf"^mem.json: {message}"):
            parse_centers(centers_json(dict(_STORED, **edit)), "mem.json")
    # rounding at the box's edge is not an edit
    edge = dict(_STORED, chiu={"centers": [[4.5 * (1 + 1e-12)], [-0.5]]})
    assert parse_centers(centers_json(edge), "mem.json").clusters["chiu"].centers.shape == (2, 1)


def _double_cart_csv(path: Path, y: list[str]) -> Path:
    """A double_cart_case1 log (inputs u, outputs y) with the given y cells, dt = 0.5 s."""
    rows = [f"{0.5 * k},{np.sin(0.3 * k):.6f},{cell}" for k, cell in enumerate(y)]
    path.write_text("t,u,y\n" + "\n".join(rows) + "\n")
    return path


def test_cluster_reads_its_log_with_the_read_options_of_analyze(tmp_path):
    """`cluster` read with --map only; its own error suggested --drop-nonfinite."""
    from hybridlog.errors import LogError
    from hybridlog.io import ReadOptions
    from hybridlog.jobs.cluster import discover_modes

    cells = [f"{np.cos(0.7 * k):.6f}" for k in range(60)]
    cells[20] = "nan"
    log = _double_cart_csv(tmp_path / "nan.csv", cells)
    with pytest.raises(LogError, match=r"nan\.csv, line 22.*must be finite"):
        discover_modes(log, "double_cart_case1", out=tmp_path / "refused.json")
    big = _double_cart_csv(tmp_path / "big.csv", [*cells[:20], "1e200", *cells[21:]])
    with pytest.raises(LogError, match=r"big\.csv, line 22.*--drop-nonfinite drops"):
        discover_modes(big, "double_cart_case1", out=tmp_path / "refused.json")
    assert list(tmp_path.glob("refused*")) == []
    read = ReadOptions(drop_nonfinite=True, resample="linear")
    for source, dropped in ((log, "nonfinite_dropped"), (big, "out_of_range_dropped")):
        out = tmp_path / f"{source.stem}_centers.json"
        outcome = discover_modes(source, "double_cart_case1", out=out, read=read)
        reading = json.loads(out.read_text())["reading"]
        assert reading[dropped] == {"y": 1} and reading["format"] == "csv"
        assert outcome.chiu.details["sizes"].sum() == 60


def test_data_too_short_to_cluster_is_an_error_naming_the_log():
    """k-means on fewer distinct regression vectors than modes named no log."""
    from hybridlog.errors import DataShortError, LogError
    from hybridlog.estimators.chiu import mode_classifier
    from hybridlog.model.cache import load_model
    from hybridlog.signals import AlignedSignals

    model = load_model("double_cart_case1")

    def signals(n: int) -> AlignedSignals:
        return AlignedSignals(
            source="runs/flat.csv",
            time=0.5 * np.arange(n),
            input_names=("u",),
            output_names=("y",),
            inputs=np.zeros((n, 1)),
            outputs=np.ones((n, 1)),
        )

    # one regression vector, repeated: Chiu finds one centre, k-means cannot find two
    assert len(mode_classifier(model, signals(40), ChiuOptions()).centers) == 1
    phi = r"φ\(k\) = \[y\(k\), y\(k-1\), u\(k-1\)\]"
    with pytest.raises(LogError) as caught:
        mode_classifier(model, signals(40), KMeansOptions())
    message = str(caught.value)
    assert re.fullmatch(
        rf"runs/flat\.csv: kmeans cannot cluster its regression vectors {phi}: clusters: the "
        r"data have fewer than 2 distinct points \(1 among 39\)",
        message,
    ), message
    assert isinstance(caught.value.__cause__, DataShortError)
    for options in (ChiuOptions(), KMeansOptions()):
        algorithm = "chiu" if isinstance(options, ChiuOptions) else "kmeans"
        with pytest.raises(
            LogError,
            match=rf"^runs/flat\.csv: {algorithm} cannot cluster its regression vectors {phi}: "
            r"output_lags, input_lags: too few samples for lags up to 1: 1, at least 2 needed$",
        ):
            mode_classifier(model, signals(1), options)
    # the algorithms over arrays know no file: the error names the option and the counts
    with pytest.raises(DataShortError, match=r"^clusters: .* \(1 among 3\)$"):
        kmeans_clustering(np.zeros((3, 2)), 2)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        # a misspelt key was ignored: the labels came from the log, not from the file
        (
            lambda d: d["chiu"].update(moeds=d["chiu"].pop("modes")),
            r"^mem.json: chiu.moeds: not a key of 'chiu' \(.*\); did you mean 'modes'\?$",
        ),
        (lambda d: d.update(centres=[[0.0]]), r"^mem.json: centres: not a key of a centres file"),
        # a mode listed twice was taken: the file's modes are compared with the model's as a set
        (
            lambda d: d.update(mode_ids=["a", "b", "b"]),
            r"^mem.json: mode_ids: the mode 'b' is listed twice$",
        ),
        (lambda d: d["scaling"].update(mid=[0.0]), r"^mem.json: scaling.mid: not a key of"),
        (
            lambda d: d["chiu"]["parameters"].update(radious=0.3),
            r"^mem.json: chiu.parameters.radious: not a key .*; did you mean 'radius'\?$",
        ),
        (
            lambda d: d["chiu"].update(decision_values=[[4.0]]),
            r"^mem.json: chiu.decision_values: expected a list of 2 rows of numbers$",
        ),
    ],
)
def test_a_key_hybridlog_does_not_write_is_refused(edit, message):
    content = copy.deepcopy({**_STORED, "chiu": {**_STORED["chiu"], "parameters": {"radius": 0.5}}})
    edit(content)
    with pytest.raises(OptionError, match=message):
        parse_centers(centers_json(content), "mem.json")


def test_an_unknown_key_as_long_as_a_file_is_quoted_cut():
    """A hand-made key of 4 million characters (or one holding a line break) was written
    whole into the error, matched by difflib against every known key on the way (a 20 MB
    key took 0.9 GB and 2.8 s); the line break read as a space.  Now quoted, cut and
    escaped, as other values of the file are, and suggested nothing."""
    import tracemalloc

    content = copy.deepcopy(_STORED)
    content["chiu"]["moeds" + "y" * 4_000_000] = 1
    text = centers_json(content)
    tracemalloc.start()
    try:
        with pytest.raises(OptionError) as caught:
            parse_centers(text, "mem.json")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert re.fullmatch(
        r"mem.json: chiu.'moedsy+…y+': not a key of 'chiu' \([a-z_, ]+\)", str(caught.value)
    ), str(caught.value)
    assert len(str(caught.value)) < 300
    assert peak < 8 * len(text)
    content = copy.deepcopy(_STORED)
    content["bo\ngus"] = 1
    with pytest.raises(OptionError, match=r"^mem.json: 'bo\\ngus': not a key of a centres file"):
        parse_centers(centers_json(content), "mem.json")


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        # each was taken without a word: the edited decision values or lags ignored, the
        # recorded radius reported as what the centres were fitted with
        (
            lambda d: d["chiu"].update(decision_values=[[4.0], [1.0]]),
            r"chiu.decision_values: not the y\(k\) components of the file's chiu.centers",
        ),
        (
            lambda d: d.update(output_lags=[0, 2]),
            r"output_lags \[0, 2\], input_lags \[\] do not give the file's regressors",
        ),
        (
            lambda d: d.update(output_lags=[1]),
            r"output_lags \[1\], input_lags \[\] do not give the file's regressors",
        ),
        (
            lambda d: d["chiu"]["parameters"].update(radius="big"),
            r"chiu.parameters.radius: chiu option 'radius': expected a finite number, got the "
            r"string 'big'",
        ),
        (
            lambda d: d.update(kmeans={**d["chiu"], "parameters": {"clusters": 3}}),
            r"kmeans.parameters.clusters: 3, but the file holds 2 kmeans centres",
        ),
        (  # a copy of centre 1 labelled otherwise: refused before the log is read too
            lambda d: d["chiu"].update(
                centers=[[4.0], [0.0], [4.0]], decision_values=None, modes=["2", "1", "1"]
            ),
            r"chiu.modes: clusters 1 and 3 have the same decision values y\* = \[4\] but the "
            r"modes '2' and '1'",
        ),
    ],
)
def test_recorded_keys_that_contradict_the_centres_are_refused(edit, message):
    from hybridlog.estimators.observer_options import check_centers
    from hybridlog.model.cache import load_model

    model = load_model("double_cart_case1")  # one output y, one input u
    content = copy.deepcopy(
        {
            **_STORED,
            "model": model.name,
            "mode_ids": list(model.mode_ids),
            "chiu": {
                "centers": [[4.0], [0.0]],
                "decision_values": [[4.0], [0.0]],
                "modes": ["2", "1"],
                "parameters": {"radius": 0.5},
            },
        }
    )
    options: ChiuOptions | KMeansOptions = ChiuOptions(output_lags="0", input_lags="")
    check_centers(model, options, centers=parse_centers(centers_json(content), "mem.json"))
    edit(content)
    if "kmeans" in content:
        options = KMeansOptions(output_lags="0", input_lags="")
    with pytest.raises(OptionError, match=r"^centers=mem.json: " + message):
        check_centers(model, options, centers=parse_centers(centers_json(content), "mem.json"))


def test_a_key_given_twice_is_refused():
    # json keeps the last of two "modes": the labels added by hand above it were dropped
    text = centers_json(_STORED)
    doubled = text.replace('"modes": [', '"modes": ["a", "a"],\n    "modes": [', 1)
    assert doubled != text
    with pytest.raises(
        OptionError, match=r"^mem.json: the key 'modes' is given twice in one object; keep one$"
    ):
        parse_centers(doubled, "mem.json")


def test_centres_of_another_dt_are_refused_naming_both(tmp_path):
    """A model copied with ``dt = 0.25`` was refused only as "another version" of it.

    The message listed equations, parameters, noise or names; the time step, which decides
    the samples φ(k) spans, was not among them.  A file made by hand (no ``model_key``)
    that records ``dt`` was not checked on it at all.
    """
    from hybridlog.estimators.observer_options import check_centers
    from hybridlog.model.builtins import builtin_text
    from hybridlog.model.cache import load_model

    fine = load_model("double_cart_case1")
    path = tmp_path / "dc1.toml"
    path.write_text(builtin_text("double_cart_case1").replace("dt = 0.5", "dt = 0.25", 1))
    other = load_model(str(path))
    content = {
        **_STORED,
        "model": fine.name,
        "dt": 0.5,
        "mode_ids": list(fine.mode_ids),
        "chiu": {"centers": [[4.0], [0.0]], "modes": ["2", "1"]},
    }
    options = ChiuOptions(output_lags="0", input_lags="")
    check_centers(fine, options, centers=parse_centers(centers_json(content), "mem.json"))
    with pytest.raises(
        OptionError,
        match=r"^centers=mem.json: dt: the centres were fitted for model 'double_cart_case1' "
        r"with dt = 0.5 s, this one's dt is 0.25 s",
    ):
        check_centers(other, options, centers=parse_centers(centers_json(content), "mem.json"))
    for bad in (0, -1.0, "0.5", True):
        with pytest.raises(OptionError, match=r"^mem.json: dt: expected a positive number"):
            parse_centers(centers_json({**content, "dt": bad}), "mem.json")


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('outputs = ["y"]', 'outputs = ["z"]', r"regressors \['y\(k\)'\] do not match .*'z\(k\)'"),
        (
            "[modes.2]",
            "[modes.3]",
            r"mode_ids: the centres were fitted for the modes 1, 2, .* 1, 3",
        ),
        (
            "[0.7627, 0.4596",
            "[0.7628, 0.4596",
            r"model_key: the centres were fitted for another version",
        ),
    ],
)
def test_centres_of_an_edited_model_are_refused_naming_what_differs(tmp_path, old, new, message):
    """A renamed output or mode was refused only as "another version" of the model.

    The model's content key differs for any edit; the modes and the regressors name what.
    """
    from hybridlog.estimators.observer_options import check_centers
    from hybridlog.model.builtins import builtin_text
    from hybridlog.model.cache import load_model
    from hybridlog.model.compiled import model_key

    fine = load_model("double_cart_case1")
    text = builtin_text("double_cart_case1")
    assert old in text
    path = tmp_path / "dc1.toml"
    path.write_text(text.replace(old, new, 1))
    content = {
        **_STORED,
        "model": fine.name,
        "model_key": model_key(fine),
        "mode_ids": list(fine.mode_ids),
        "chiu": {"centers": [[4.0], [0.0]], "modes": ["2", "1"]},
    }
    centers = parse_centers(centers_json(content), "mem.json")
    options = ChiuOptions(output_lags="0", input_lags="")
    check_centers(fine, options, centers=centers)
    with pytest.raises(OptionError, match=r"^(centers=)?mem.json: " + message):
        check_centers(load_model(str(path)), options, centers=centers)


def test_stored_centres_say_where_the_log_leaves_the_range_they_were_fitted_on():
    # Centres fitted on a cart moving ±1 m decided a log recorded in micrometres (10^6
    # times larger) by the nearest centre without a word: report.md said 93 % mode accuracy
    # and nothing of the extrapolation.  A log slightly outside is a note, one far outside
    # (beyond the range's own width) a WARNING, one inside nothing.
    y, _ = _two_blobs()  # inside the file's scaling [-0.5, 4.5]
    spec = RegressorSpec(output_lags=(0,), input_lags=())
    stored = parse_centers(centers_json(_STORED), "mem.json")

    def notes(outputs):
        found = stored_classifier(
            stored, "chiu", spec, outputs, names=["y(k)"], mode_ids=["a", "b"], source="m.json"
        )
        return found.notes[1:]

    assert notes(y) == ()
    slightly = y.copy()
    slightly[[10, 200]] = [[-1.0], [np.nan]]  # 0.1 of the width below; NaN: not measured
    (note,) = notes(slightly)
    assert note.startswith(
        "1 of 299 samples have y(k) outside the range the centres of m.json were fitted on "
        "(its scaling); farthest y(k) = -1 at sample 10, beyond [-0.5, 4.5] by 0.1 times its "
        "width: the nearest-centre decision (eqs. (2)-(3)) extrapolates there"
    )
    (warning,) = notes(y * 1e6)
    assert warning.startswith("WARNING: 300 of 300 samples have y(k) outside the range")
    top = float(y.max()) * 1e6
    assert f"farthest y(k) = {top:.6g} at sample {int(y.argmax())}," in warning
    assert f"by {(top - 4.5) / 5:.3g} times its width" in warning


def test_an_output_constant_in_the_centres_file_is_measured_as_the_decision_scales_it():
    # A range of one value in the file had an infinite 'width': y2 a nanometre off the
    # constant it was fitted at was a WARNING ("beyond [0, 0] by a constant in the file"),
    # and named the farthest over y1 recorded 10^6 times larger.  The decision does not
    # scale such an output (decide_clusters divides by 1): nor does the note.
    stored = parse_centers(
        centers_json(
            {
                **_STORED,
                "regressors": ["y1(k)", "y2(k)"],
                "scaling": {"lower": [-0.5, 0.0], "upper": [4.5, 0.0]},
                "chiu": {"centers": [[4.0, 0.0], [0.0, 0.0]], "modes": ["b", "a"]},
            }
        ),
        "mem.json",
    )
    y, _ = _two_blobs()
    spec = RegressorSpec(output_lags=(0,), input_lags=())

    def note(outputs):
        found = stored_classifier(
            stored,
            "chiu",
            spec,
            outputs,
            names=["y1(k)", "y2(k)"],
            mode_ids=["a", "b"],
            source="m.json",
        )
        (only,) = found.notes[1:]
        return only

    off = np.full((300, 1), 1e-9)
    assert note(np.hstack([y, off])).startswith("300 of 300 samples")  # a note, no WARNING
    assert "beyond [0, 0] by 1e-09 (one value in the file: compared unscaled" in note(
        np.hstack([y, off])
    )
    assert "farthest y1(k) = " in note(np.hstack([y * 1e6, off]))


@pytest.mark.parametrize("n", [6, 7])
def test_labelling_as_many_clusters_as_modes_past_the_exhaustive_search_finds_the_best_map(
    n: int,
) -> None:
    """k-means' k clusters for k modes: no single move is admissible, only exchanges.

    With 6 modes (6^6 maps, past EXHAUSTIVE_MAX) the coordinate descent stopped at its
    round-robin start: on a simulated 6-mode log kmeans' labels scored a one-step SSE of
    17.7 (mode accuracy 5 %) where the exhaustive search found 5.7 (31 %).
    """
    rng = np.random.default_rng(n)
    truth = rng.permutation(n)  # the map of lowest score
    cost = rng.uniform(1.0, 2.0, size=(n, n))
    cost[np.arange(n), truth] = 0.0

    def score(labels: np.ndarray) -> float:
        return float(cost[np.arange(n), labels].sum())

    labels = label_clusters(n, [f"m{i}" for i in range(n)], score, np.full(n, 10))
    assert "coordinate descent" in labels.notes[0]
    assert labels.modes.tolist() == truth.tolist()
    assert labels.score == 0.0


def test_the_notes_of_many_clusters_list_the_first_and_count_the_rest() -> None:
    """A centres file of 200,000 clusters gave report.md a line per cluster (11 MB)."""
    from hybridlog.cluster.labels import MOST_CLUSTER_NOTES, cluster_notes

    n = MOST_CLUSTER_NOTES + 150
    modes = np.arange(n) % 2
    sizes = np.zeros(n, dtype=np.int64)
    sizes[:3] = 5
    sizes[-1] = 7  # a cluster past the listed ones still decides samples
    notes = cluster_notes(modes, sizes, ["1", "2"])
    assert len(notes) == MOST_CLUSTER_NOTES + 1
    assert notes[0].startswith("cluster 1 (5 samples) -> mode '1'")
    assert notes[-1].startswith(
        f"clusters {MOST_CLUSTER_NOTES + 1} to {n}: 150 more, not listed (149 of them decide no "
        "sample)"
    )
    # a handful of clusters is listed in full, as before
    assert len(cluster_notes(modes[:4], sizes[:4], ["1", "2"])) == 4


_TWINS = {  # centres whose y(k) (the decision values, eq. (3)) repeat an earlier centre's
    "a copy of a centre": [[0.0, 1.0], [4.0, 2.0], [0.0, 1.0]],
    "another u(k-1) at the same y(k)": [[0.0, 1.0], [4.0, 2.0], [0.0, -1.0]],
    "y(k) = -0.0 beside 0.0": [[0.0, 1.0], [4.0, 2.0], [-0.0, 3.0]],
}


@pytest.mark.parametrize("kind", list(_TWINS))
def test_twins_given_other_modes_by_hand_are_refused(kind):
    """Clusters of the same decision values cannot be told apart by eq. (3): every sample
    went to the first, so a centres file (or cluster_modes) giving the later one another
    mode was used as the order of the centres says, the later one's mode never decided."""
    y, _ = _two_blobs()
    spec = RegressorSpec(output_lags=(0,), input_lags=(1,))
    content = copy.deepcopy(_STORED)
    content.update(regressors=["y(k)", "u(k-1)"], input_lags=[1])
    content["scaling"] = {"lower": [-0.5, -1.0], "upper": [4.5, 3.0]}
    content["chiu"] = {"centers": _TWINS[kind], "modes": ["a", "b", "b"]}
    stored = parse_centers(centers_json(content), "mem.json")
    names = ["y(k)", "u(k-1)"]
    with pytest.raises(
        OptionError,
        match=r"^mem.json: chiu.modes: clusters 1 and 3 have the same decision values y\* = "
        r"\[0\] but the modes 'a' and 'b': eq. \(3\) cannot tell them apart",
    ):
        stored_classifier(
            stored, "chiu", spec, y, names=names, mode_ids=["a", "b"], source="mem.json"
        )
    content["chiu"]["modes"] = ["a", "b", "a"]  # one mode: the order of the centres is moot
    stored = parse_centers(centers_json(content), "mem.json")
    found = stored_classifier(
        stored, "chiu", spec, y, names=names, mode_ids=["a", "b"], source="mem.json"
    )
    assert found.details["sizes"].tolist() == [150, 150, 0]
    values = np.array(_TWINS[kind])[:, :1]
    with pytest.raises(OptionError, match=r"^cluster_modes=a,b,b: clusters 1 and 3 have"):
        manual_labels("a,b,b", ["a", "b"], 3, decision_values=values)
    assert manual_labels("a,b,a", ["a", "b"], 3, decision_values=values).tolist() == [0, 1, 0]
    # labelled from the data, a twin takes its twin's mode (so hybridlog's own centres
    # file of them reads back), and the note says why it decides no sample
    labels = label_clusters(
        3,
        ["a", "b"],
        lambda labels: float(labels[0] != 0) + float(labels[1] != 1),
        np.array([150, 150, 0]),
        twins=decision_twins(values),
    )
    assert labels.modes.tolist() == [0, 1, 0]
    assert labels.notes[-1] == (
        "cluster 3 decides no sample (its decision values are cluster 1's, which eq. (3) "
        "decides): unused (labelled 'a')"
    )
