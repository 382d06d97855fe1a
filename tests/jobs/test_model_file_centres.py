"""A centres file named by a model file, and centres checked before any log is read."""

import json
from pathlib import Path

import pytest

from hybridlog.errors import ModelError, OptionError
from hybridlog.estimators.observer_options import ChiuOptions
from hybridlog.estimators.registry import prepare
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.cluster import discover_modes
from hybridlog.jobs.compare import compare
from hybridlog.jobs.estimation import estimator_inputs
from hybridlog.model.builtins import builtin_text as builtin_source
from hybridlog.model.cache import load_model
from tests.support.paths import SAMPLE_LOGS

LOG = SAMPLE_LOGS / "double_cart_case1.csv"


def _model_beside_centres(tmp_path: Path, table: str) -> Path:
    """double_cart_case1 as a file in models/, its [estimators.chiu] ``table``; centres there."""
    folder = tmp_path / "models"
    folder.mkdir()
    model = folder / "dc1.toml"
    model.write_text(builtin_source("double_cart_case1"))
    discover_modes(LOG, model, out=folder / "c.json", compare_kmeans=True)
    model.write_text(builtin_source("double_cart_case1") + f"\n[estimators.chiu]\n{table}\n")
    return model


def test_a_relative_centres_path_in_a_model_file_is_from_its_folder(tmp_path, monkeypatch):
    """`centers = "c.json"` beside the model was looked for in the working directory."""
    model = _model_beside_centres(tmp_path, 'centers = "c.json"')
    elsewhere = tmp_path / "work"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    analyze(LOG, model, estimator="chiu", out_dir="out")
    report = json.loads(Path("out/report.json").read_text())
    assert report["options"]["centers"] == str(model.parent / "c.json")
    assert report["notes"][0].endswith(f"centres loaded from {model.parent / 'c.json'}")
    # a missing file is named with the model's key; --set stays from the working directory
    model.write_text(model.read_text().replace('"c.json"', '"gone.json"'))
    with pytest.raises(OptionError, match=r"dc1.toml: estimators.chiu.centers: .*gone.json: no"):
        analyze(LOG, model, estimator="chiu", out_dir="refused")
    with pytest.raises(OptionError, match=r"^c.json: no such centers file"):
        analyze(LOG, model, estimator="chiu", sets=["centers=c.json"], out_dir="refused")
    assert not Path("refused").exists()


def test_a_clustering_option_must_be_the_one_the_centres_were_fitted_with(tmp_path):
    """`radius = 0.3` in the model file made every centres file unusable ("has no effect")."""
    model = _model_beside_centres(tmp_path, 'centers = "c.json"\nradius = 0.3')
    # the file was fitted (by cluster, from that table) before radius was added: refused,
    # naming the model's key and the file's value
    with pytest.raises(
        OptionError,
        match=r"radius=0.3 \(.*dc1.toml: estimators.chiu.radius\) does not match the file's "
        r"chiu centres, fitted with radius=0.5",
    ):
        analyze(LOG, model, estimator="chiu", out_dir=tmp_path / "refused")
    with pytest.raises(OptionError, match=r"--set radius=0.4 does not match"):
        analyze(LOG, model, estimator="chiu", sets=["radius=0.4"], out_dir=tmp_path / "refused")
    # fitted again (cluster starts from the model's table): they agree, and the report says 0.3
    discover_modes(LOG, model, out=model.parent / "c.json", force=True, compare_kmeans=True)
    analyze(LOG, model, estimator="chiu", out_dir=tmp_path / "ok")
    options = json.loads((tmp_path / "ok" / "report.json").read_text())["options"]
    assert options["radius"] == 0.3 and options["squash"] == 1.25
    # k-means records what it was fitted with too, restarts and seed included
    stored = json.loads((model.parent / "c.json").read_text())["kmeans"]["parameters"]
    assert stored == {"clusters": 2, "restarts": 10, "seed": 0}
    with pytest.raises(OptionError, match=r"--set seed=3 does not match .* fitted with seed=0"):
        analyze(
            LOG,
            model,
            estimator="kmeans",
            sets=[f"centers={model.parent / 'c.json'}", "seed=3"],
            out_dir=tmp_path / "refused",
        )
    assert not (tmp_path / "refused").exists()


def test_centres_for_another_model_are_refused_before_the_log_is_read(tmp_path):
    """A wrong centres file failed only after the whole log had been read (in a batch: on
    every log); the corrupt log here would fail first if it were read."""
    model = _model_beside_centres(tmp_path, 'centers = "c.json"')
    corrupt = tmp_path / "corrupt.csv"
    corrupt.write_text("t,u,y\n0,1\n")
    other = tmp_path / "dc2.toml"
    other.write_text(
        builtin_source("double_cart_case2")
        + f'\n[estimators.chiu]\ncenters = "{model.parent}/c.json"\n'
    )
    with pytest.raises(
        OptionError, match=r"model: the centres were fitted for model 'double_cart_case1'"
    ):
        analyze(corrupt, other, estimator="chiu", out_dir=tmp_path / "refused")
    with pytest.raises(OptionError, match=r"--set output_lags=0 does not match|regressors"):
        compare(
            corrupt,
            model,
            ["imm", "chiu"],
            sets=["output_lags=0"],
            out_dir=tmp_path / "refused",
        )
    assert not (tmp_path / "refused").exists()
    with pytest.raises(ModelError):  # the refusal of a bad model file still comes first
        bad = tmp_path / "bad.toml"
        bad.write_text("name = 1\n")
        analyze(LOG, bad, estimator="chiu", out_dir=tmp_path / "refused")


def test_centres_of_an_edited_model_of_the_same_name_are_refused(tmp_path):
    """Centres of a model whose two modes' dynamics were swapped since were used silently.

    The clusters are labelled as modes by how well each mode's equations predict the log, so
    after the swap every sample was classified into the mode whose equations are now the
    other's (VAF 99.74 % → 99.09 %, exit 0).  centers.json records the model's content key.
    """
    text = builtin_source("double_cart_case1")
    model = tmp_path / "dc1.toml"
    model.write_text(text)
    centres = tmp_path / "c.json"
    discover_modes(LOG, model, out=centres)
    assert len(json.loads(centres.read_text())["model_key"]) == 64
    analyze(LOG, model, estimator="chiu", sets=[f"centers={centres}"], out_dir=tmp_path / "ok")
    first, second = text.index("[modes.1]"), text.index("[modes.2]")
    end = text.index("[noise]")
    one = text[first:second].replace("[modes.1]", "[modes.2]").replace("x3 <= 0", "x3 > 0")
    two = text[second:end].replace("[modes.2]", "[modes.1]").replace("x3 > 0", "x3 <= 0")
    model.write_text(text[:first] + two + one + text[end:])
    with pytest.raises(
        OptionError, match=r"c.json: model_key: .* another version of model 'double_cart_case1'"
    ):
        analyze(LOG, model, estimator="chiu", sets=[f"centers={centres}"], out_dir=tmp_path / "no")
    assert not (tmp_path / "no").exists()
    # a file without the key (made by hand) is checked on its name, modes and regressors
    content = json.loads(centres.read_text())
    del content["model_key"]
    centres.write_text(json.dumps(content))
    analyze(LOG, model, estimator="chiu", sets=[f"centers={centres}"], out_dir=tmp_path / "hand")
    content["model_key"] = "not a key"
    centres.write_text(json.dumps(content))
    with pytest.raises(OptionError, match=r"c.json: model_key: expected 64 hexadecimal digits"):
        analyze(LOG, model, estimator="chiu", sets=[f"centers={centres}"], out_dir=tmp_path / "no")


def test_loaded_centres_refuse_a_given_default_and_name_the_file_as_the_origin(tmp_path):
    """`--set radius=0.5` (the default) beside centres fitted with 0.3 ran with 0.3, and
    report.json said `"radius": 0.3` from `--set radius=0.5`, or from `default` unset; lags
    that do not give the file's regressors were refused without naming where they were set."""
    centres = tmp_path / "c.json"
    discover_modes(
        LOG, "double_cart_case1", out=centres, chiu=ChiuOptions(radius=0.3), compare_kmeans=True
    )
    with pytest.raises(OptionError, match=r"--set radius=0.5 does not match .* radius=0.3"):
        analyze(
            LOG,
            "double_cart_case1",
            estimator="chiu",
            sets=[f"centers={centres}", "radius=0.5"],
            out_dir=tmp_path / "refused",
        )
    assert not (tmp_path / "refused").exists()
    analyze(
        LOG,
        "double_cart_case1",
        estimator="chiu",
        sets=[f"centers={centres}"],
        out_dir=tmp_path / "ok",
    )
    report = json.loads((tmp_path / "ok" / "report.json").read_text())
    assert report["options"]["radius"] == 0.3
    assert report["origins"]["options.radius"] == f"{centres}: chiu.parameters.radius"
    assert report["origins"]["options.decay_rate"] == "default"  # not the file's: the LMI's
    # kmeans' clusters = none is the number of modes, which the file records: it agrees
    model = load_model("double_cart_case1")
    kmeans = prepare(model, "kmeans", {"centers": str(centres), "clusters": "none"})
    assert estimator_inputs(kmeans, model)["centers"].model == "double_cart_case1"
    # lags the centres were not fitted with: the message named the file, not where they were set
    mine = tmp_path / "mine.toml"
    mine.write_text(
        builtin_source("double_cart_case1")
        + f'\n[estimators.chiu]\ncenters = "{centres.name}"\noutput_lags = "0,2"\n'
    )
    with pytest.raises(
        OptionError,
        match=r"fitted with output_lags=0,1 \(not .*mine.toml: estimators.chiu.output_lags = "
        r"0,2\): set the same$",
    ):
        estimator_inputs(prepare(load_model(mine), "chiu"), load_model(mine))


def test_centres_fitted_with_another_simulation_input_fit_the_same_plant(tmp_path):
    """Centres fitted with a copy whose only edits were in ``[simulation]`` were refused.

    The built-in model refused them as "another version of model 'double_cart_case1' (its
    equations, parameters, noise or names differ)", which none did: the key the file
    recorded held the simulation's input, which labels no cluster.  The edited equations
    are still refused, and a file that records the old key (input included) still loads.
    """
    from hybridlog.model.compiled import model_key

    text = builtin_source("double_cart_case1")
    edited = tmp_path / "square.toml"
    # another simulated input and true initial state: [simulation] only, which simulate reads
    square = text.replace('u = "sin(0.3*t)"', 'u = "sign(sin(0.3*t))"')
    square = square.replace("state = [0.5, 0.0, -0.5, 0.0]", "state = [0.2, 0.0, -0.1, 0.0]")
    assert square.count("sign(") == 1 and "[0.2, 0.0, -0.1, 0.0]" in square
    edited.write_text(square)
    centres = tmp_path / "c.json"
    discover_modes(LOG, edited, out=centres)
    analyze(
        LOG,
        "double_cart_case1",
        estimator="chiu",
        sets=[f"centers={centres}"],
        out_dir=tmp_path / "builtin",
    )
    assert (tmp_path / "builtin" / "report.json").exists()
    content = json.loads(centres.read_text())
    content["model_key"] = model_key(load_model("double_cart_case1"))
    centres.write_text(json.dumps(content))
    analyze(
        LOG,
        "double_cart_case1",
        estimator="chiu",
        sets=[f"centers={centres}"],
        out_dir=tmp_path / "old",
    )
    damped = text.replace("[0.342, 0.09981, -0.3598, 0.5203]", "[0.342, 0.09981, -0.3598, 0.6]")
    assert damped != text
    edited.write_text(damped)
    discover_modes(LOG, edited, out=tmp_path / "c2.json")
    with pytest.raises(OptionError, match=r"c2.json: model_key: .* another version of model"):
        analyze(
            LOG,
            "double_cart_case1",
            estimator="chiu",
            sets=[f"centers={tmp_path / 'c2.json'}"],
            out_dir=tmp_path / "no",
        )


def test_a_centres_file_not_in_utf8_is_named_as_a_model_file_is(tmp_path):
    """A centres file saved as UTF-16 (Notepad's "Unicode") or Latin-1 read "cannot read:
    'utf-8' codec can't decode byte 0xff in position 0: invalid start byte": Python's words,
    a byte offset.  Now the line of the byte, or the UTF-16 byte-order mark, as a model file
    says them."""
    from hybridlog.jobs.centers import read_centers

    discover_modes(LOG, "double_cart_case1", out=tmp_path / "c.json")
    text = (tmp_path / "c.json").read_text()
    (tmp_path / "u16.json").write_text(text, encoding="utf-16")
    latin = text.replace('"model": "double_cart_case1"', '"model": "double_cart_case1\xe9"', 1)
    (tmp_path / "latin.json").write_bytes(latin.encode("latin-1"))
    with pytest.raises(OptionError, match=r"u16.json: not UTF-8: the file is UTF-16 \(it starts"):
        read_centers(tmp_path / "u16.json")
    line = latin[: latin.index("\xe9")].count("\n") + 1
    with pytest.raises(
        OptionError, match=rf"latin.json: line {line}: not UTF-8 \(byte 0xe9\); save the file as"
    ):
        read_centers(tmp_path / "latin.json")
    assert read_centers(tmp_path / "c.json").model == "double_cart_case1"
