"""What a model reference means: `--set` names, the default estimator, built-ins beside folders."""

import pytest

from hybridlog.errors import ModelError, OptionError
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.compare import compare
from hybridlog.jobs.simulate import simulate_log
from tests.support.paths import SAMPLE_LOGS

LOG = SAMPLE_LOGS / "double_cart_case1.csv"

# A linear two-mode model whose parameter is named like hstf's forgetting factor rho.
MODEL = """
name = "gain"
dt = 0.1
states = ["x"]
inputs = ["u"]
outputs = ["y"]
default_estimator = "{default}"

[parameters]
rho = 0.9

[modes.1]
A = [["rho"]]
B = [[0.1]]
C = [[1.0]]

[modes.2]
A = [[0.5]]
B = [[0.1]]
C = [[1.0]]

[noise]
process = 0.01
measurement = 0.01

[initial]
state = [0.0]
covariance = 1.0
"""


def test_a_set_name_both_a_parameter_and_an_option_is_refused(tmp_path):
    """`--set rho=0.5 --estimator hstf` changed the model's rho; hstf's stayed 0.95."""
    model = tmp_path / "gain.toml"
    model.write_text(MODEL.format(default="imm"))
    log = tmp_path / "log.csv"
    log.write_text("t,u,y\n" + "".join(f"{k / 10},{k % 3},{k % 5}\n" for k in range(40)))
    with pytest.raises(
        OptionError,
        match=r"^--set rho=0.5: 'rho' is both a parameter of model .*gain.toml and an option "
        r"of hstf, and --set would change the parameter only",
    ):
        analyze(log, model, estimator="hstf", sets=["rho=0.5"], out_dir=tmp_path / "refused")
    with pytest.raises(OptionError, match=r"an option of hstf"):
        compare(log, model, ["imm", "hstf"], sets=["rho=0.5"], out_dir=tmp_path / "refused")
    assert not (tmp_path / "refused").exists()
    # no estimator run has the option: the parameter, as documented
    analyze(log, model, estimator="imm", sets=["rho=0.5"], out_dir=tmp_path / "imm")
    assert (tmp_path / "imm" / "report.json").is_file()


def test_a_set_name_of_an_unused_parameter_and_an_option_says_both(tmp_path):
    """A leftover parameter named like an option: refused as "would change nothing" alone.

    The user meant the option, which would change the run: the refusal says what stands in
    its way.
    """
    model = tmp_path / "gain.toml"
    model.write_text(MODEL.format(default="imm").replace("rho = 0.9", "rho = 0.9\ntheta = 1"))
    log = tmp_path / "log.csv"
    log.write_text("t,u,y\n" + "".join(f"{k / 10},{k % 3},{k % 5}\n" for k in range(40)))
    with pytest.raises(
        ModelError,
        match=r"parameters\.theta: used by no expression of the model, so --set theta=\.\.\. "
        r"would change nothing; 'theta' is also an option of hstf, which --set cannot reach "
        r"while the model has a parameter of that name: remove or rename the parameter, or "
        r"set the option under \[estimators\.hstf\]$",
    ):
        analyze(log, model, estimator="hstf", sets=["theta=0.5"], out_dir=tmp_path / "refused")
    assert not (tmp_path / "refused").exists()


def test_the_refusal_of_a_name_both_a_parameter_and_an_option_quotes_the_set_as_typed(tmp_path):
    """It wrote the value with six digits: `--set rho=0.123457` for `--set rho=0.123456789`."""
    model = tmp_path / "gain.toml"
    model.write_text(MODEL.format(default="hstf"))
    with pytest.raises(OptionError, match=r"^--set rho=0\.123456789: 'rho' is both"):
        analyze(LOG, model, sets=["rho=0.123456789"], out_dir=tmp_path / "refused")
    assert not (tmp_path / "refused").exists()


def test_a_default_estimator_typo_is_an_error_whichever_estimator_runs(tmp_path):
    """It was checked only when the default was used, so the file's typo waited unseen."""
    model = tmp_path / "gain.toml"
    model.write_text(MODEL.format(default="imn"))
    with pytest.raises(ModelError, match=r"gain.toml: default_estimator: unknown estimator 'imn'"):
        analyze(LOG, model, estimator="imm", out_dir=tmp_path / "refused")
    assert not (tmp_path / "refused").exists()


def test_a_batch_beside_a_folder_named_like_its_built_in_model(tmp_path, monkeypatch):
    """With a folder three_tank_hstf/ (earlier outputs) in the working directory, every log
    of `batch --model three_tank_hstf` failed: 'cannot read model file: Is a directory'."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "three_tank_hstf").mkdir()
    simulate_log("three_tank_hstf", "run.csv", steps=30)
    outcome = run_batch(["run.csv"], "three_tank_hstf", out_dir="out", estimator="imm")
    assert outcome.failed == 0, outcome.logs
