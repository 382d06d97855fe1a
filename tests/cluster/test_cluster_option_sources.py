"""``hybridlog cluster``: options out of bounds named where they were set; notes that say it."""

from pathlib import Path

import numpy as np
import pytest

from hybridlog.model.builtins import builtin_text
from tests.support.cli import run_main
from tests.support.paths import SAMPLE_LOGS

# never read: the options are refused before the log is
LOG = "no_such_log.csv"


def _cluster(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], model: str, *options: str
) -> tuple[int, str]:
    args = ["cluster", LOG, "--model", model, "--out", str(tmp_path / "c.json"), *options]
    return run_main(args, capsys)


@pytest.mark.parametrize(
    ("options", "named"),
    [
        # --help gives squash "in [1, 100]" and accept, reject "in [0, 1]"; these edges said
        # "squash: ..." and "accept, reject: ...", naming no flag the user gave
        (["--squash", "1"], "--squash: 1 is outside (1, 100]"),
        # --help said accept "in [0, 1]", but 0 leaves no reject in 0 < reject < accept
        (["--accept", "0"], "--accept: 0 is outside (0, 1]"),
    ],
)
def test_a_flag_out_of_bounds_is_named(tmp_path, capsys, options, named):
    code, stderr = _cluster(tmp_path, capsys, "double_cart_case1", *options)
    assert code == 2 and stderr == f"hybridlog cluster: {named} (see hybridlog cluster --help)\n"
    assert not (tmp_path / "c.json").exists()


@pytest.mark.parametrize(
    ("options", "named"),
    [
        (["--reject", "0.5"], "accept 0.5 (the default), --reject 0.5: need 0 < reject < accept"),
        (["--accept", "0.2", "--reject", "0.3"], "--accept 0.2, --reject 0.3: need 0 < reject <"),
    ],
)
def test_flags_that_do_not_go_together_are_named(tmp_path, capsys, options, named):
    code, stderr = _cluster(tmp_path, capsys, "double_cart_case1", *options)
    assert code == 2 and stderr.startswith(f"hybridlog: error: {named}"), stderr
    assert len(stderr.splitlines()) == 1 and not (tmp_path / "c.json").exists()


def test_a_flag_goes_with_the_model_files_values(tmp_path, capsys):
    # --reject 0.7 was refused against accept's dataclass default, "0.7 is not below
    # accept = 0.5 (its default)", where the model file's accept = 0.9 is the default
    model = tmp_path / "dc.toml"
    model.write_text(builtin_text("double_cart_case1") + "\n[estimators.chiu]\naccept = 0.9\n")
    code, stderr = _cluster(tmp_path, capsys, str(model), "--reject", "0.7")
    assert code == 2 and stderr.startswith("hybridlog: error: no_such_log.csv"), stderr


@pytest.mark.parametrize(
    ("options", "named"),
    [
        # the lags were checked only when φ(k) was built: "output_lags: must contain 0",
        # naming neither --output-lags nor --set output_lags nor the model file's key
        (["--output-lags", "1"], "--output-lags: must contain 0"),
        (["--input-lags", "0,0"], "--input-lags: a lag is listed twice"),
        (["--input-lags", "-1"], "--input-lags: lags must be non"),
    ],
)
def test_lags_are_named_where_they_were_set(tmp_path, capsys, options, named):
    code, stderr = _cluster(tmp_path, capsys, "double_cart_case1", *options)
    assert code == 2 and stderr.startswith(f"hybridlog cluster: {named}"), stderr
    assert len(stderr.splitlines()) == 1 and not (tmp_path / "c.json").exists()


def test_lags_set_elsewhere_are_named_there(tmp_path, capsys):
    model = tmp_path / "dc.toml"
    model.write_text(builtin_text("double_cart_case1") + "\n[estimators.chiu]\noutput_lags = '1'\n")
    code, stderr = _cluster(tmp_path, capsys, str(model))
    assert code == 2
    assert stderr.startswith(f"hybridlog: error: {model}: estimators.chiu.output_lags: chiu")
    args = ["analyze", LOG, "--model", "double_cart_case1", "--estimator", "kmeans"]
    code, stderr = run_main(
        [*args, "--set", "output_lags=1,2", "--out", str(tmp_path / "r")], capsys
    )
    assert code == 2
    assert stderr.startswith("hybridlog: error: --set output_lags=1,2: kmeans option 'output_lags'")


def test_a_model_file_value_out_of_bounds_names_its_key(tmp_path, capsys):
    model = tmp_path / "dc.toml"
    model.write_text(builtin_text("double_cart_case1") + "\n[estimators.chiu]\nsquash = 1.0\n")
    code, stderr = _cluster(tmp_path, capsys, str(model))
    assert code == 2
    assert stderr.startswith(f"hybridlog: error: {model}: estimators.chiu.squash: chiu option")
    # the flag overrides the table, but the table's bad value is an error of the file still
    code, stderr = _cluster(tmp_path, capsys, str(model), "--squash", "2")
    assert code == 2 and stderr.startswith(f"hybridlog: error: {model}: estimators.chiu.squash")


def test_an_approximate_grid_too_coarse_names_the_flags(tmp_path, capsys):
    """Found on the data: it said "method: ... use method=exact", a key the command line
    does not have (its flags are --exact and --approximate)."""
    log = str(SAMPLE_LOGS / "double_cart_case1.csv")
    args = ["cluster", log, "--model", "double_cart_case1", "--out", str(tmp_path / "c.json")]
    code, stderr = run_main([*args, "--approximate", "--radius", "0.001"], capsys)
    assert code == 2 and len(stderr.splitlines()) == 1
    assert stderr.startswith("hybridlog: error: --approximate, --radius 0.001: the approximate")
    assert "use --exact (O(N²))" in stderr and not (tmp_path / "c.json").exists()


def test_notes_on_a_log_at_rest_say_what_was_found():
    """A log at rest (y and u constant) was said to have '2 of 3 dimensions constant, left
    out' (all 3 were; one is kept), and one vector gave '1 centres from 1 regression
    vectors', '(auto: 1 points ...)' and 'cluster 1 (1 samples)'."""
    from hybridlog.cluster.classifier import fit_classifier
    from hybridlog.cluster.labels import cluster_notes
    from hybridlog.cluster.regressors import RegressorSpec
    from hybridlog.cluster.subtractive import SubtractiveOptions, subtractive_clustering

    y, u = np.ones((50, 1)), np.zeros((50, 1))
    names = ["y(k)", "y(k-1)", "u(k-1)"]
    fitted = fit_classifier(y, u, RegressorSpec(), SubtractiveOptions(), names=names, n_modes=2)
    assert "; all 3 dimensions constant: every point the same;" in fitted.notes[0]
    assert fitted.notes[0].startswith("chiu: 1 centre from 49 regression vectors ")
    one = fit_classifier(
        y[:2], u[:2], RegressorSpec(), SubtractiveOptions(), names=names, n_modes=2
    )
    assert one.notes[0].startswith("chiu: 1 centre from 1 regression vector φ(k)")
    assert "(auto: 1 point <= " in one.notes[0]
    single = subtractive_clustering(np.ones((5, 1)))
    assert "; the only dimension constant: every point the same" in single.notes[0]
    varying = subtractive_clustering(np.c_[np.arange(5.0), np.ones(5)])
    assert "; 1 of 2 dimensions constant, left out" in varying.notes[0]
    notes = cluster_notes(np.array([0, 1]), np.array([1, 2]), ("a", "b"))
    assert notes[:2] == ["cluster 1 (1 sample) -> mode 'a'", "cluster 2 (2 samples) -> mode 'b'"]


@pytest.mark.parametrize(
    ("table", "named"),
    [
        # cluster read only the keys it knew: `radiuss` fitted the default 0.5 silently,
        # where analyze refuses the model file
        ("[estimators.chiu]\nradiuss = 0.3\n", "estimators.chiu.radiuss: chiu has no option"),
        ("[estimators.kmeans]\nclusterz = 3\n", "estimators.kmeans.clusterz: kmeans has no"),
        ("[estimators.chu]\nradius = 0.3\n", "estimators.chu: unknown estimator"),
    ],
)
def test_a_model_file_table_analyze_refuses_is_refused(tmp_path, capsys, table, named):
    model = tmp_path / "dc.toml"
    model.write_text(builtin_text("double_cart_case1") + "\n" + table)
    code, stderr = _cluster(tmp_path, capsys, str(model))
    assert code == 2, stderr
    assert stderr.startswith(f"hybridlog: error: {model}: {named}"), stderr
    assert len(stderr.splitlines()) == 1 and not (tmp_path / "c.json").exists()


@pytest.mark.parametrize(
    ("options", "named"),
    [
        # refused only once the log was read and clustered, as "cluster_modes: unknown mode"
        # (now as the estimator is prepared, naming the estimator's option too)
        (
            ["--set", "cluster_modes=7,1"],
            "--set cluster_modes=7,1: {estimator} option 'cluster_modes': "
            "unknown mode '7' (modes: 1",
        ),
        (
            ["--set", "cluster_modes=1,,2"],
            "--set cluster_modes=1,,2: {estimator} option 'cluster_modes': "
            "item 2 of '1,,2' is empty",
        ),
    ],
)
def test_cluster_modes_are_checked_before_the_log_is_read(tmp_path, capsys, options, named):
    for estimator in ("chiu", "kmeans"):
        args = ["analyze", LOG, "--model", "double_cart_case1", "--estimator", estimator]
        code, stderr = run_main([*args, *options, "--out", str(tmp_path / "r")], capsys)
        expected = named.format(estimator=estimator)
        assert code == 2 and stderr.startswith(f"hybridlog: error: {expected}"), stderr


def test_cluster_modes_of_a_model_file_are_named_by_their_key(tmp_path, capsys):
    model = tmp_path / "dc.toml"
    text = builtin_text("double_cart_case1")
    model.write_text(text + "\n[estimators.chiu]\ncluster_modes = '2,1'\n")
    # the sample log gives 3 chiu centres: the message named neither the file nor the key
    args = ["cluster", str(SAMPLE_LOGS / "double_cart_case1.csv"), "--model", str(model)]
    code, stderr = run_main([*args, "--out", str(tmp_path / "c.json")], capsys)
    assert code == 2 and not (tmp_path / "c.json").exists()
    assert stderr == (
        f"hybridlog: error: {model}: estimators.chiu.cluster_modes = '2,1': 2 mode ids for 3 "
        "chiu centres; give one per centre\n"
    )
    # with centres loaded, the count is checked before the log is read
    centres = tmp_path / "c3.json"
    code, _ = run_main([*args[:3], "double_cart_case1", "--out", str(centres)], capsys)
    assert code == 0
    model.write_text(text + f"\n[estimators.chiu]\ncluster_modes = '2,1'\ncenters = '{centres}'\n")
    code, stderr = run_main(
        ["analyze", LOG, "--model", str(model), "--out", str(tmp_path / "r")], capsys
    )
    assert code == 2
    assert stderr.startswith(f"hybridlog: error: {model}: estimators.chiu.cluster_modes = '2,1'")
    # kmeans' labels, from its own table, are checked before the log is read
    model.write_text(text + "\n[estimators.kmeans]\ncluster_modes = '2,7'\n")
    code, stderr = _cluster(tmp_path, capsys, str(model), "--compare-kmeans")
    assert code == 2
    assert stderr.startswith(f"hybridlog: error: {model}: estimators.kmeans.cluster_modes: kmeans")


def test_kmeans_lags_of_a_model_file_that_are_not_chius_are_refused(tmp_path, capsys):
    # --compare-kmeans fitted k-means on chiu's φ(k) without a word; the kmeans estimator,
    # taking its table's lags, then refused the file it had written
    model = tmp_path / "dc.toml"
    text = builtin_text("double_cart_case1")
    model.write_text(text + "\n[estimators.kmeans]\noutput_lags = '0'\n")
    code, stderr = _cluster(tmp_path, capsys, str(model), "--compare-kmeans")
    assert code == 2 and not (tmp_path / "c.json").exists()
    assert stderr == (
        f"hybridlog: error: {model}: estimators.kmeans.output_lags = '0': --compare-kmeans "
        "fits k-means on chiu's φ(k) (output_lags 0,1), the one the centres file holds; set "
        "the same lags for chiu and kmeans\n"
    )
    # the same lags, written otherwise, are the same
    model.write_text(text + "\n[estimators.kmeans]\noutput_lags = ' 0, 1'\n")
    args = ["cluster", str(SAMPLE_LOGS / "double_cart_case1.csv"), "--model", str(model)]
    code, _ = run_main([*args, "--out", str(tmp_path / "c.json"), "--compare-kmeans"], capsys)
    assert code == 0


def test_analyze_names_clustering_bounds_before_the_log_is_read(tmp_path, capsys):
    # analyze found squash = 1 only in the estimator, after reading the log, and said
    # "squash: ..." without --set or the model file's key
    args = ["analyze", LOG, "--model", "double_cart_case1", "--estimator", "chiu"]
    code, stderr = run_main([*args, "--set", "squash=1", "--out", str(tmp_path / "r")], capsys)
    assert code == 2
    assert stderr == (
        "hybridlog: error: --set squash=1: chiu option 'squash': 1 is outside (1, 100]\n"
    )
    model = tmp_path / "dc.toml"
    model.write_text(builtin_text("double_cart_case1") + "\n[estimators.chiu]\naccept = 0.1\n")
    code, stderr = run_main(
        ["analyze", LOG, "--model", str(model), "--out", str(tmp_path / "r")], capsys
    )
    assert code == 2
    assert stderr.startswith(
        f"hybridlog: error: {model}: estimators.chiu.accept: chiu option 'reject': 0.15 is not "
    )


@pytest.mark.parametrize("command", ["analyze", "compare"])
def test_a_grid_too_coarse_for_the_log_is_an_option_error_of_chiu(tmp_path, capsys, command):
    # the grid is chosen on the data: the error comes from the estimator's run, whose
    # ClusteringOptionError did not survive the worker's pickle (analyze) nor compare's
    # re-raise with the estimator's name: "unexpected TypeError"
    log = str(SAMPLE_LOGS / "double_cart_case1.csv")
    which = ["--estimator", "chiu"] if command == "analyze" else ["--estimators", "chiu,kmeans"]
    sets = ["--set", "method=approximate", "--set", "radius=0.001"]
    args = [command, log, "--model", "double_cart_case1", *which, *sets]
    code, stderr = run_main([*args, "--out", str(tmp_path / "r")], capsys)
    prefix = "" if command == "analyze" else "--estimators chiu: "
    assert code == 2 and not (tmp_path / "r").exists()
    assert stderr.startswith(
        f"hybridlog: error: {prefix}chiu option method=approximate, radius=0.001: the "
        "approximate potentials need a grid"
    ), stderr


def test_a_clustering_option_error_survives_a_pickle():
    import pickle

    from hybridlog.cluster.subtractive import ClusteringOptionError

    err = ClusteringOptionError(("squash",), "squash: r_b/r_a must be greater than 1, got 1.0")
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is ClusteringOptionError and back.keys == ("squash",)
    assert str(back) == str(err) and back.reason == err.reason
