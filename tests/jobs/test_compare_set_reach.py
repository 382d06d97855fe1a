"""``compare`` with a ``--set`` that reaches only some of the estimators it compares.

``--set NAME=VALUE`` goes to every compared estimator that has the option, and is refused
only when none would read it.  ``compare --estimators hstf,imm --set rho=0.9`` tuned hstf
alone (imm has no ``rho``), and ``--estimators imm,unknown-mode --set beam=5`` reached
unknown-mode alone (imm has a ``beam``, read only with ``mode_sequence = kbest``): the
table then set a tuned estimator beside an untuned one, and nothing, not the terminal nor
comparison.md, said so.  Now each such ``--set`` is a note on stderr and a line under
comparison.md's "Given to some estimators only" (:func:`set_reach`).
"""

from __future__ import annotations

from pathlib import Path

from hybridlog.errors import OptionError
from hybridlog.estimators import get_estimator
from hybridlog.estimators.offline_options import lacks, not_offered
from hybridlog.jobs.compare import compare
from hybridlog.jobs.overrides import parse_sets, prepare_estimators, set_reach
from tests.cli.test_cli import run
from tests.support.cpha import CPHA_EXAMPLE
from tests.support.paths import SAMPLE_LOGS

TANK = SAMPLE_LOGS / "three_tank_hstf.csv"
RHO = "--set rho=0.9 reaches hstf alone: imm has no option rho"


def _reach(model: str | Path, names: list[str], sets: list[str]) -> list[str]:
    loaded, overrides = parse_sets(sets, model)
    prepared = prepare_estimators(loaded, names, overrides, given_by="--estimators")
    return set_reach(loaded, prepared, overrides)


def test_an_option_some_estimators_lack_or_do_not_read_is_said(tmp_path: Path) -> None:
    assert _reach("three_tank_hstf", ["hstf", "imm"], ["rho=0.9"]) == [RHO]
    # an offline pass's option says why, as its refusal does (was "hstf has no option smooth")
    hstf = get_estimator("hstf")
    for sets in (["smooth=true"], ["mode_sequence=viterbi"], ["mode_sequence=argmax"]):
        name, value = sets[0].split("=")
        assert _reach("three_tank_hstf", ["imm", "hstf"], sets) == [
            f"--set {name}={value} reaches imm alone: hstf {lacks(hstf, name, value)}"
        ]
        assert lacks(hstf, name, value).startswith("does not offer it: ")
        assert not_offered(hstf, name, value, []).startswith(lacks(hstf, name, value))
    model = tmp_path / "cpha.toml"
    model.write_text(CPHA_EXAMPLE)
    assert _reach(model, ["imm", "unknown-mode"], ["beam=5"]) == [
        "--set beam=5 reaches unknown-mode alone: on imm it has no effect: only "
        "mode_sequence = kbest keeps mode histories (here argmax); add --mode-sequence kbest, "
        "or leave beam unset"
    ]
    # what reaches every estimator is not said: a parameter, an option each has and reads
    assert _reach(model, ["imm", "unknown-mode"], ["beam=5", "mode_sequence=kbest"]) == []
    assert _reach("three_tank_hstf", ["hstf", "imm"], ["A=150"]) == []
    assert _reach("three_tank_hstf", ["hstf"], ["rho=0.9"]) == []


def test_the_comparison_and_the_terminal_say_what_a_set_reached(tmp_path: Path) -> None:
    out = tmp_path / "cmp"
    outcome = compare(TANK, "three_tank_hstf", ["hstf", "imm"], out_dir=out, sets=["rho=0.9"])
    assert outcome.reach == [RHO]
    text = (out / "comparison.md").read_text(encoding="utf-8")
    assert f"\n## Given to some estimators only\n\n- {RHO}\n" in text
    args = ["compare", str(TANK), "--model", "three_tank_hstf", "--estimators", "hstf,imm"]
    result = run([*args, "--set", "rho=0.9", "--out", str(tmp_path / "cli")])
    assert f"hybridlog: note: {RHO}\n" in result.stderr
    result = run([*args, "--out", str(tmp_path / "plain")])
    assert "reaches" not in result.stderr
    assert "Given to some" not in (tmp_path / "plain" / "comparison.md").read_text()


def test_an_option_named_after_its_estimator_says_how_set_takes_it() -> None:
    # "--set imm.beam=4": "neither a parameter ... nor an estimator option ...; did you mean
    # 'unknown_mode'?" for unknown-mode.beam, a name no estimator has
    for names, sets, owner in (
        (["imm", "hstf"], ["imm.beam=4"], "imm"),
        (["hstf"], ["imm.beam=4"], "imm"),
        (["imm"], ["unknown-mode.beam=3"], "unknown-mode"),
    ):
        try:
            _reach("three_tank_hstf", names, sets)
        except OptionError as err:
            option, value = sets[0].split(".", 1)[1].split("=")
            assert str(err) == (
                f"--set {sets[0]}: --set takes an estimator's option by its name alone (--set "
                f"{option}={value}), for every estimator run that has it; for {owner} alone, set "
                f"it under [estimators.{owner}] in the model file"
            )
        else:
            raise AssertionError(f"{sets} taken")
