"""``hybridlog cluster`` on long work: the up-front note and the progress bar on stderr."""

import json

import pytest
from click.testing import CliRunner

from hybridlog.cli import cli
from hybridlog.cluster import potentials, subtractive
from tests.support.paths import SAMPLE_LOGS


@pytest.mark.parametrize("quiet", [False, True])
def test_cluster_says_how_long_the_exact_potentials_take(tmp_path, monkeypatch, quiet):
    # 10^6 rows of the three-tank log ran the exact potentials for 15 minutes without a word;
    # the time is now said up front on stderr (not with --quiet; the bar only on a terminal).
    monkeypatch.setattr(potentials, "PAIRS_PER_STEP", 2_000)
    monkeypatch.setattr(subtractive, "_CALIBRATION_S", 0.0)
    monkeypatch.setattr(subtractive, "LONG_WORK_S", 0.0)
    log = SAMPLE_LOGS / "double_cart_case1.csv"
    args = ["cluster", str(log), "--model", "double_cart_case1", "--exact"]
    args += ["--out", str(tmp_path / "c.json"), *(["--quiet"] if quiet else [])]
    result = CliRunner().invoke(cli, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    if quiet:
        assert result.stderr == "" and result.stdout == ""
    else:
        # prefixed as every other note, and saying the way out (it printed the bare line)
        note = result.stderr.splitlines()
        assert len(note) == 1, result.stderr
        assert note[0].startswith("hybridlog: note: exact potentials of "), result.stderr
        assert " on this machine with " in note[0] and "requested); " in note[0]
        assert note[0].endswith(
            "; method=approximate takes the grid's approximate potentials instead"
        )
        assert "| chiu | 1 |" in result.stdout


_JOINTLY_UNSTABLE = """
name = "joint"
time = "discrete"
dt = 1.0
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]

[modes.1]
A = [[0.5, 2.0], [0.0, 0.5]]
B = [1.0, 0.0]
C = [0.0, 0.0]

[modes.2]
A = [[0.5, 0.0], [2.0, 0.5]]
B = [1.0, 0.0]
C = [0.0, 0.0]

[noise]
process = 0.0
measurement = 1e-6

[initial]
state = [0.0, 0.0]
covariance = 1.0
mode = "1"
"""


def test_clusters_a_linear_model_cannot_label_say_why_not_that_it_is_not_linear(tmp_path):
    """Two linear modes, each stable, unstable when switched, seen by no output: the LMI
    (15) has no solution, so no observer scores the labellings.  The clusters' labelling,
    in centers.json and the printed notes, said "clusters not labelled (the model is not
    linear)" of this linear model; the LMI's reason was one more note, printed only."""
    import numpy as np

    from hybridlog.jobs.cluster import discover_modes

    model = tmp_path / "joint.toml"
    model.write_text(_JOINTLY_UNSTABLE)
    rng = np.random.default_rng(3)
    log = tmp_path / "log.csv"
    u, y = rng.normal(size=(2, 60))
    rows = [f"{t}.0,{a:.17g},{b:.17g}" for t, (a, b) in enumerate(zip(u, y, strict=True))]
    log.write_text("t,u,y\n" + "\n".join(rows) + "\n")
    out = tmp_path / "c.json"
    outcome = discover_modes(log, model, out=out, compare_kmeans=True)
    stored = json.loads(out.read_text())
    for algorithm in ("chiu", "kmeans"):
        (said,) = [n for n in stored[algorithm]["labelling"] if "not labelled" in n]
        assert said.startswith("clusters not labelled as modes: ")
        assert "LMI (15)" in said and "jointly" in said and "not linear" not in said
        assert stored[algorithm]["modes"] is None
    assert not any("not linear" in note for note in outcome.notes)
