"""``hybridlog compare`` and ``hybridlog cluster`` as a demanding user runs them."""

from __future__ import annotations

import csv
import json
import os
import shutil
from pathlib import Path

import pytest

from hybridlog.errors import ModelError, OptionError
from hybridlog.estimators import ESTIMATORS
from hybridlog.estimators.capabilities import ModelTraits
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.cluster import discover_modes
from hybridlog.jobs.compare import compare
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import load_model
from hybridlog.report.markdown import escape_markdown
from tests.support.paths import ROOT

CART = ROOT / "sample_logs" / "double_cart_case1.csv"


def _oddly_named(tmp_path: Path) -> Path:
    """The double-cart sample under a name that is not UTF-8 (``b\\xffd.csv``)."""
    log = Path(os.fsdecode(os.fsencode(tmp_path) + b"/b\xffd.csv"))
    shutil.copyfile(CART, log)
    return log


def test_a_log_named_in_bytes_that_are_not_utf8_is_named_as_ls_shows_it(tmp_path: Path) -> None:
    """compare ended in 'unexpected UnicodeEncodeError' writing comparison.md's title, and
    cluster wrote the lone surrogate into centers.json's log key (JSON that strict readers
    refuse)."""
    log = _oddly_named(tmp_path)
    shown = str(tmp_path / "b\\xffd.csv")
    out = tmp_path / "cmp"
    compare(log, "double_cart_case1", ["imm", "chiu"], out_dir=out)
    title = (out / "comparison.md").read_text(encoding="utf-8").splitlines()[0]
    assert title == f"# double_cart_case1 on {escape_markdown(shown)}"
    centres = tmp_path / "c.json"
    discover_modes(log, "double_cart_case1", out=centres)
    text = centres.read_text(encoding="utf-8")
    assert json.loads(text)["log"] == shown and "\\udcff" not in text


def test_the_comparison_holds_each_estimators_own_numbers(tmp_path: Path) -> None:
    """comparison.csv's raw values are those of each estimator's report.json, bit for bit."""
    out = tmp_path / "cmp"
    outcome = compare(CART, "double_cart_case1", ["chiu", "kmeans", "imm"], out_dir=out)
    with (out / "comparison.csv").open(newline="") as file:
        rows = {row["estimator"]: row for row in csv.DictReader(file)}
    assert list(rows) == ["chiu", "kmeans", "imm"]
    for name, report in outcome.reports.items():
        stored = json.loads((out / name / "report.json").read_text())
        for column, value in (
            ("vaf", stored["vaf"]),
            ("fit", stored["fit"]),
            ("mse", stored["mse"]),
            ("mode_accuracy", stored["modes"]["accuracy"]),
            ("detection_delay_s", stored["modes"]["detection_delay_s"]),
        ):
            assert rows[name][column] == ("" if value is None else repr(value)), (name, column)
        assert report.mse == stored["mse"]


def test_an_error_of_one_compared_estimator_names_it(tmp_path: Path) -> None:
    """``--set cluster_modes=2,1`` reaches chiu (3 clusters) and kmeans (2): the error named
    neither, and nothing is written."""
    out = tmp_path / "cmp"
    with pytest.raises(
        OptionError, match=r"^--estimators chiu: cluster_modes: 2 mode ids for 3 clusters"
    ):
        compare(
            CART, "double_cart_case1", ["kmeans", "chiu"], out_dir=out, sets=["cluster_modes=2,1"]
        )
    assert not out.exists()
    # one estimator is named by the command already: the message stays as analyze gives it
    with pytest.raises(OptionError, match=r"^cluster_modes: 2 mode ids for 3 clusters"):
        compare(CART, "double_cart_case1", ["chiu"], out_dir=out, sets=["cluster_modes=2,1"])


def test_a_run_error_of_a_model_file_option_names_its_key(tmp_path: Path) -> None:
    """The same labels written in the model file: 'cluster_modes: 2 mode ids for 3
    clusters', naming neither the file nor the key (given by --set, the --set is named)."""
    model = tmp_path / "cart.toml"
    model.write_text(
        builtin_text("double_cart_case1") + "\n[estimators.chiu]\ncluster_modes = '2,1'\n"
    )
    with pytest.raises(
        ModelError, match=rf"^{model}: estimators\.chiu\.cluster_modes: 2 mode ids for 3 clusters"
    ):
        analyze(CART, model, estimator="chiu", out_dir=tmp_path / "r")
    assert not (tmp_path / "r").exists()


def test_a_small_radius_still_gives_a_readable_plot(tmp_path: Path) -> None:
    """r_a = 0.001 gave 840 clusters, each its own legend entry and dashed line: the legend
    pushed the axes to nothing (matplotlib's 'constrained_layout not applied' on stderr) and
    ten colours repeated over 840 clusters.  Now the samples are coloured by mode."""
    from hybridlog.estimators.chiu import ChiuOptions

    out = tmp_path / "c.json"
    outcome = discover_modes(CART, "double_cart_case1", out=out, chiu=ChiuOptions(radius=0.001))
    assert len(outcome.chiu.centers) > 100
    assert (tmp_path / "c.png").stat().st_size > 0


def test_the_comparison_says_which_estimator_missed_which_gate(tmp_path: Path) -> None:
    """The gates' outcome was only on stderr: comparison.md, a CI job's summary, had none."""
    out = tmp_path / "cmp"
    outcome = compare(
        CART,
        "double_cart_case1",
        ["imm", "hstf"],
        out_dir=out,
        fail_under=["vaf=99.97"],
        fail_over=["detection_delay_s=10"],
    )
    assert outcome.gate_failures == [
        "hstf: vaf = 99.9655 is under the bound 99.97",
        "hstf: detection_delay_s is not available (every true switch (48) was missed), so the "
        "--fail-over bound 10 cannot be met",
    ]
    with (out / "comparison.csv").open(newline="") as file:
        gates = {row["estimator"]: row["gates"] for row in csv.DictReader(file)}
    assert gates == {
        "imm": "pass (2)",
        "hstf": "FAIL: "
        + "; ".join(failure.removeprefix("hstf: ") for failure in outcome.gate_failures),
    }
    table = (out / "comparison.md").read_text().splitlines()
    assert table[2].startswith("| estimator |") and table[2].endswith("| gates | warnings |")
    assert table[4].endswith("| pass (2) | 0 |") and "| FAIL: vaf = 99.9655" in table[5]
    # no gates, no column
    compare(CART, "double_cart_case1", ["imm"], out_dir=tmp_path / "plain")
    assert "gates" not in (tmp_path / "plain" / "comparison.csv").read_text()


def test_cluster_refuses_its_settings_before_reading_the_log(tmp_path: Path) -> None:
    """``--squash 1`` and ``--output-lags 1`` were refused after the log was read (and the
    LMI solved): here the log is a folder no reader could read."""
    from hybridlog.estimators.chiu import ChiuOptions

    folder = tmp_path / "not_a_log.csv"
    folder.mkdir()
    for options, message in (
        # each field read as --squash and --output-lags are (named as the field of chiu=)
        (ChiuOptions(squash=1.0), r"^chiu.squash: 1 is outside \(1, 100\]"),
        (ChiuOptions(output_lags="1"), r"^chiu.output_lags: must contain 0"),
        (ChiuOptions(accept=0.1, reject=0.2), r"^accept, reject: need 0 < reject < accept"),
    ):
        with pytest.raises(OptionError, match=message):
            discover_modes(folder, "double_cart_case1", out=tmp_path / "c.json", chiu=options)


def test_different_numbers_side_by_side_never_read_alike(tmp_path: Path) -> None:
    """imm's VAF 99.9721 and hstf's 99.9655 both read '99.97' in comparison.md (and hstf
    missed a gate at 99.97 its cell seemed to meet)."""
    from hybridlog.report.summary_tables import markdown_table

    outcome = compare(CART, "double_cart_case1", ["imm", "hstf"], out_dir=tmp_path / "cmp")
    vaf = {name: report.vaf for name, report in outcome.reports.items()}
    assert f"{vaf['imm']:.2f}" == f"{vaf['hstf']:.2f}"  # the case at hand
    rows = (tmp_path / "cmp" / "comparison.md").read_text().splitlines()[4:6]
    cells = [row.split(" | ")[1] for row in rows]
    assert cells == [f"{vaf['imm']:.3f}", f"{vaf['hstf']:.3f}"] and cells[0] != cells[1]
    # the digits grow only as far as needed, in either notation; equal values stay as they were
    rows = [[0.5, 1.00001e-9], [0.5, 1.00002e-9], [0.25, 3e-3]]
    table = markdown_table(("x", "y"), rows, distinct=True)
    assert table.splitlines()[2:] == [
        "| 0.5000 | 1.00001e-09 |",
        "| 0.5000 | 1.00002e-09 |",
        "| 0.2500 | 3.00000e-03 |",
    ]
    # a batch's many logs keep the digits of the column's smallest value
    many = markdown_table(("y",), [[y] for _, y in rows[:2]])
    assert many.splitlines()[2:] == ["| 1.000e-09 |"] * 2


def test_an_estimator_named_twice_is_named(tmp_path: Path) -> None:
    """``imm,chiu,imm`` was refused as 'an estimator is named twice', not saying which."""
    with pytest.raises(OptionError, match=r"^--estimators: 'imm' named twice$"):
        compare(CART, "double_cart_case1", ["imm", "chiu", "imm"], out_dir=tmp_path / "c")
    assert not (tmp_path / "c").exists()


def test_estimators_joined_by_another_separator_are_told_to_use_commas(tmp_path: Path) -> None:
    """``imm;hstf`` was 'unknown estimator ... did you mean 'hstf'?', as if hstf alone."""
    for joined in ("imm;hstf", "imm hstf"):
        with pytest.raises(
            OptionError,
            match=rf"^--estimators: '{joined}' is 2 estimators; separate them "
            r"with commas: imm,hstf$",
        ):
            compare(CART, "double_cart_case1", [joined], out_dir=tmp_path / "c")
    with pytest.raises(OptionError, match=r"unknown estimator 'imm;hsft'"):  # not two names
        compare(CART, "double_cart_case1", ["imm;hsft"], out_dir=tmp_path / "c")
    assert not (tmp_path / "c").exists()


def test_a_centres_file_named_in_bytes_that_are_not_utf8(tmp_path: Path) -> None:
    """Its name went into the notes as a lone surrogate: analyze and compare ended in
    'unexpected UnicodeEncodeError in writer.py' writing report.md, after the estimators ran."""
    from hybridlog.jobs.analysis import analyze

    fitted = tmp_path / "fitted.json"
    discover_modes(CART, "double_cart_case1", out=fitted)
    centres = Path(os.fsdecode(os.fsencode(tmp_path) + b"/c\xff.json"))
    shutil.copyfile(fitted, centres)
    shown = escape_markdown(f"{tmp_path}/c\\xff.json")  # the notes, as report.md shows text
    sets = [f"centers={centres}"]
    analyze(CART, "double_cart_case1", estimator="chiu", sets=sets, out_dir=tmp_path / "a")
    text = (tmp_path / "a" / "report.md").read_text(encoding="utf-8")
    assert f"- chiu: 3 centres loaded from {shown}" in text
    compare(CART, "double_cart_case1", ["chiu", "imm"], sets=sets, out_dir=tmp_path / "c")
    text = (tmp_path / "c" / "comparison.md").read_text(encoding="utf-8")
    assert f"- labels loaded from {shown}" in text


def test_cluster_fits_what_the_chiu_estimator_fits_for_the_model(tmp_path: Path) -> None:
    """A model file's ``[estimators.chiu] radius = 0.3`` set the chiu estimator's fit, but
    ``hybridlog cluster`` ignored it and fitted r_a = 0.5: other centres than analyze's."""
    from hybridlog.errors import ModelError
    from hybridlog.estimators.chiu import ChiuOptions
    from hybridlog.jobs.analysis import analyze
    from hybridlog.model.builtins import builtin_text

    model = tmp_path / "cart.toml"
    text = builtin_text("double_cart_case1")
    tables = "[estimators.chiu]\nradius = 0.3\n[estimators.kmeans]\nclusters = 3\n"
    tables += 'cluster_modes = "2,1,1"'
    model.write_text(f"{text}\n{tables}\n")
    out = tmp_path / "c.json"
    outcome = discover_modes(CART, model, out=out, compare_kmeans=True)
    stored = json.loads(out.read_text())
    assert stored["chiu"]["parameters"]["radius"] == 0.3
    assert len(stored["kmeans"]["centers"]) == 3 and stored["kmeans"]["modes"] == ["2", "1", "1"]
    report = analyze(CART, model, estimator="chiu", out_dir=tmp_path / "a").report
    assert stored["chiu"]["centers"] == report.options["classifier"]["centers"]
    assert stored["chiu"]["modes"] == report.options["classifier"]["cluster_modes"]
    assert len(outcome.chiu.centers) == 6
    # what the user gives wins over the model file, and so does a whole ChiuOptions
    for chiu, given in ((ChiuOptions(radius=0.5), ["radius"]), (ChiuOptions(radius=0.5), None)):
        discover_modes(CART, model, out=out, chiu=chiu, given=given, force=True)
        assert json.loads(out.read_text())["chiu"]["parameters"]["radius"] == 0.5
    model.write_text(text + '\n[estimators.chiu]\nradius = "big"\n')
    with pytest.raises(ModelError, match=r"cart\.toml: estimators\.chiu\.radius: chiu option"):
        discover_modes(CART, model, out=tmp_path / "never.json")
    assert not (tmp_path / "never.json").exists()


def test_cluster_command_gives_its_options_over_the_model_files(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from hybridlog.cli import cli
    from hybridlog.model.builtins import builtin_text

    model = tmp_path / "cart.toml"
    model.write_text(builtin_text("double_cart_case1") + "\n[estimators.chiu]\nradius = 0.3\n")
    out = tmp_path / "c.json"
    for extra, radius in (([], 0.3), (["--radius", "0.5"], 0.5), (["--radius", "0.4"], 0.4)):
        args = ["cluster", str(CART), "--model", str(model), "--out", str(out), "--force"]
        result = CliRunner().invoke(cli, [*args, *extra])
        assert result.exit_code == 0, result.output
        assert json.loads(out.read_text())["chiu"]["parameters"]["radius"] == radius


def test_every_estimator_that_cannot_run_is_named_at_once(tmp_path: Path) -> None:
    """All seven estimators on the double cart named switching-observer alone; taken out,
    the next run refused unknown-mode, then sliding-mode.  Two typos were found one a run."""
    from hybridlog.errors import ModelError

    every = ["hstf", "imm", "chiu", "kmeans", "switching-observer", "unknown-mode", "sliding-mode"]
    # the registry's list, in its order: an estimator added to it runs on the cart too
    traits = ModelTraits(load_model("double_cart_case1"))
    suited = ", ".join(n for n, e in ESTIMATORS.items() if e.capabilities.mismatch(traits) is None)
    assert {"hstf", "imm", "chiu", "kmeans"} <= set(suited.split(", "))
    out = tmp_path / "cmp"
    with pytest.raises(ModelError) as refused:
        compare(CART, "double_cart_case1", every, out_dir=out)
    assert str(refused.value) == (
        "double_cart_case1: --estimators: 3 of the 7 estimators cannot run this model: "
        "'switching-observer', 'sliding-mode' (needs a continuous-time model), 'unknown-mode' "
        f"(needs a model with [components]); estimators for this model: {suited}"
    )
    with pytest.raises(OptionError) as unknown:
        compare(CART, "double_cart_case1", ["imx", "imm", "kmean", "ice"], out_dir=out)
    assert str(unknown.value) == (
        "double_cart_case1: --estimators: 3 of the 4 estimators cannot run this model: "
        "'imx' (unknown; did you mean 'imm'?), 'kmean' (unknown; did you mean 'kmeans'?), "
        f"'ice' (unknown); estimators for this model: {suited}"
    )
    assert not out.exists()


def test_a_report_of_a_comparison_is_not_replaced_on_its_own(tmp_path: Path) -> None:
    """``analyze --out cmp/imm --force`` replaced the comparison's imm report with a run of
    other settings, and ``compare --out cmp/imm --force`` put a comparison there: cmp's
    comparison.md then gave numbers, and a link, that no report of it held any more."""
    from hybridlog.errors import OutputError
    from hybridlog.jobs.analysis import analyze

    out = tmp_path / "cmp"
    compare(CART, "double_cart_case1", ["imm", "hstf"], out_dir=out)
    before = (out / "imm" / "report.json").read_bytes()
    part = r"output directory .*cmp/imm is part of .*cmp, which hybridlog wrote"
    with pytest.raises(OutputError, match=part):
        analyze(CART, "double_cart_case1", estimator="imm", out_dir=out / "imm", force=True)
    with pytest.raises(OutputError, match=part):
        compare(CART, "double_cart_case1", ["hstf"], out_dir=out / "imm", force=True)
    assert (out / "imm" / "report.json").read_bytes() == before
    shutil.rmtree(out / "imm")  # gone, still named by comparison.md: not written alone either
    with pytest.raises(OutputError, match=part):
        analyze(CART, "double_cart_case1", estimator="imm", out_dir=out / "imm")
    compare(CART, "double_cart_case1", ["hstf"], out_dir=out / "other")  # not part of it
