"""``hybridlog cluster``: clustering options out of bounds are named where they were set."""

from pathlib import Path

import pytest

from hybridlog.model.builtins import builtin_text
from tests.support.cli import run_main

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
        (["--squash", "1"], "--squash 1: r_b/r_a must be greater than 1"),
        (["--accept", "0"], "--accept 0, reject 0.15 (the default): need 0 < reject < accept"),
        (["--reject", "0.5"], "accept 0.5 (the default), --reject 0.5: need 0 < reject"),
        (["--accept", "0.2", "--reject", "0.3"], "--accept 0.2, --reject 0.3: need 0 < reject"),
    ],
)
def test_a_flag_out_of_bounds_is_named(tmp_path, capsys, options, named):
    code, stderr = _cluster(tmp_path, capsys, "double_cart_case1", *options)
    assert code == 2 and stderr.startswith(f"hybridlog: error: {named}")
    assert len(stderr.splitlines()) == 1 and not (tmp_path / "c.json").exists()


def test_a_model_file_value_out_of_bounds_names_its_key(tmp_path, capsys):
    model = tmp_path / "dc.toml"
    model.write_text(builtin_text("double_cart_case1") + "\n[estimators.chiu]\nsquash = 1.0\n")
    code, stderr = _cluster(tmp_path, capsys, str(model))
    assert code == 2
    assert stderr.startswith(f"hybridlog: error: {model}: estimators.chiu.squash = 1: r_b/r_a")
    # the flag overrides the table, and is what is named when it is out of bounds too
    code, stderr = _cluster(tmp_path, capsys, str(model), "--squash", "1")
    assert code == 2 and stderr.startswith("hybridlog: error: --squash 1: r_b/r_a")
