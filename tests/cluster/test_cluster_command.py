"""``hybridlog cluster`` on long work: the up-front note and the progress bar on stderr."""

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
