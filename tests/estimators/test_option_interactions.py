"""Options whose values go together: a pair that cannot is refused, one that is inert is too.

Found in a hostile pass: ``unknown-mode`` with ``candidates`` below ``beam`` ran with the
beam as its bound while report.json recorded the smaller value; ``hstf`` with ``fading =
false`` ran the plain EKF whatever ``rho``, ``beta`` and ``likelihood`` said, and recorded
them as the options used, with a note on the faded likelihood it did not use.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from hybridlog.errors import ModelError, OptionError
from hybridlog.estimators.cpha.hypotheses import Tracker
from hybridlog.estimators.cpha.options import UnknownModeOptions
from hybridlog.estimators.hstf import (
    FADED_LIKELIHOOD_NOTE,
    UNIFORM_PREDICTION_NOTE,
    HstfOptions,
    run_hstf,
)
from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.estimators.options import OptionSource, option, parse_options
from hybridlog.estimators.registry import resolve_estimator
from hybridlog.jobs.overrides import parse_sets, prepare_estimators
from hybridlog.model.loader import load_model
from hybridlog.simulate import simulate
from tests.support.cpha import CPHA_EXAMPLE


@dataclass(frozen=True)
class Pair:
    low: int = option(1, "the lower", range=(0, 100))
    high: int = option(5, "the higher", range=(0, 100))

    def conflicts(self) -> list[tuple[str, str, str]]:
        if self.low > self.high:
            return [("low", "high", f"{self.low} is above the higher, {{other}}")]
        return []


def test_a_conflict_names_the_option_its_source_and_where_the_other_came_from() -> None:
    file_high = OptionSource.model_file("m/p.toml", "pair", "high")
    with pytest.raises(OptionError) as caught:
        parse_options(
            Pair,
            {"low": "7", "high": 6},
            estimator="pair",
            sources={"low": OptionSource.command_line("--set", "low", "7"), "high": file_high},
        )
    assert str(caught.value) == (
        "--set low=7: pair option 'low': 7 is above the higher, "
        "high = 6 (m/p.toml: estimators.pair.high)"
    )
    # only the other was given: its source is blamed, the option's default named
    with pytest.raises(ModelError) as refused:
        parse_options(Pair, {"high": 0}, estimator="pair", sources={"high": file_high})
    assert str(refused.value) == (
        "m/p.toml: estimators.pair.high: pair option 'low': 1 is above the higher, "
        "high = 0 (m/p.toml: estimators.pair.high)"
    )
    with pytest.raises(OptionError, match=r"high = 5 \(its default\)$"):
        parse_options(Pair, {"low": 9}, estimator="pair")
    assert parse_options(Pair, {"low": 5}, estimator="pair") == Pair(5, 5)


def test_unknown_mode_refuses_candidates_below_the_beam(tmp_path: Path) -> None:
    path = tmp_path / "cpha.toml"
    path.write_text(CPHA_EXAMPLE + "\n[estimators.unknown-mode]\ncandidates = 30\n")
    model, overrides = parse_sets(["beam=40"], str(path))
    with pytest.raises(ModelError) as caught:
        prepare_estimators(model, ["unknown-mode"], overrides)
    assert str(caught.value) == (
        f"{path}: estimators.unknown-mode.candidates: unknown-mode option 'candidates': 30 is "
        "below the beam, beam = 40 (--set beam=40): fewer successors would be filtered per "
        "step than hypotheses kept; give candidates >= beam, or none for 10 x beam"
    )
    model, overrides = parse_sets(["candidates=5"], str(path))
    with pytest.raises(OptionError, match=r"^--set candidates=5: .* beam = 20 \(its default\)"):
        prepare_estimators(model, ["unknown-mode"], overrides)
    model, overrides = parse_sets(["beam=30"], str(path))
    (prepared,) = prepare_estimators(model, ["unknown-mode"], overrides)
    assert prepared.options == UnknownModeOptions(beam=30, candidates=30)
    # the tracker itself no longer raises the bound without a word
    with pytest.raises(ValueError, match=r"candidates \(1\) below the beam \(2\)"):
        Tracker(
            (),
            None,  # type: ignore[arg-type]
            None,  # type: ignore[arg-type]
            np.zeros((1, 1)),
            np.zeros((1, 1)),
            beam=2,
            candidates=1,
            variance_growth=1.0,
            unknown_mode=True,
        )


@pytest.fixture(scope="module")
def three_tank():
    model = load_model("three_tank_hstf")
    log = simulate(model, steps=120, seed=3)
    return model, log.signals(model)


def test_what_hstf_calls_inert_without_fading_changes_nothing_and_with_it_changes_the_run(
    three_tank,
) -> None:
    model, signals = three_tank
    inert = HstfOptions(fading=False).inert(model)
    assert set(inert) == {"rho", "beta", "likelihood"} and HstfOptions().inert(model) == {}
    changed = {"rho": 0.3, "beta": 50.0, "likelihood": "unfaded"}
    for fading in (False, True):
        base = run_hstf(model, signals, HstfOptions(fading=fading))
        for name, value in changed.items():
            other = run_hstf(model, signals, HstfOptions(fading=fading, **{name: value}))
            same = np.array_equal(other.state_means, base.state_means) and np.array_equal(
                other.mode_probabilities, base.mode_probabilities
            )
            assert same == (not fading), (name, fading)
    # the note on the faded likelihood is this run's only where there is fading
    assert FADED_LIKELIHOOD_NOTE not in run_hstf(model, signals, HstfOptions(fading=False)).notes
    assert FADED_LIKELIHOOD_NOTE in run_hstf(model, signals, HstfOptions()).notes


def test_the_hstf_says_its_prediction_is_the_modes_mean_where_their_outputs_differ(three_tank):
    """On the three-tank (``h_i = i·x``) its fit was -29.8 % with nothing said of why."""
    model, signals = three_tank
    assert UNIFORM_PREDICTION_NOTE in run_hstf(model, signals, HstfOptions()).notes
    cart = load_model("double_cart_case1")  # C_1 = C_2: the mean is the one output equation
    log = simulate(cart, steps=20, seed=0).signals(cart, source="test")
    assert UNIFORM_PREDICTION_NOTE not in run_hstf(cart, log, HstfOptions()).notes


@pytest.mark.parametrize(
    ("name", "value"), [("rho", "0.5"), ("beta", "3"), ("likelihood", "unfaded")]
)
def test_set_of_an_hstf_option_fading_false_ignores_is_refused(name: str, value: str) -> None:
    model, overrides = parse_sets([f"{name}={value}", "fading=false"], "three_tank_hstf")
    with pytest.raises(OptionError) as caught:
        prepare_estimators(model, ["hstf"], overrides)
    assert str(caught.value).startswith(
        f"--set {name}={value}: has no effect on estimator 'hstf': fading = false fixes λ_i = 1"
    )
    model, overrides = parse_sets([f"{name}={value}"], "three_tank_hstf")
    (prepared,) = prepare_estimators(model, ["hstf"], overrides)
    assert prepared.options != HstfOptions()  # with fading, the value is the run's


ONE_MODE = """
name = "one_mode"
dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[modes.only]
A = [[0.9]]
B = [[1.0]]
C = [[1.0]]

[noise]
process = 0.01
measurement = 0.1

[initial]
state = [0.0]
covariance = [[1.0]]
mode = "only"

[simulation.inputs]
u = "sin(t/5)"
"""


def test_the_hstf_says_nothing_of_holding_the_initial_mode_on_a_one_mode_model(
    tmp_path: Path,
) -> None:
    """The faded-likelihood note (a flat posterior, θ holding the initial mode, 45 % mode
    accuracy) was in every report of the HSTF, a one-mode model's too, where the posterior
    is 1 and no mode is decided."""
    path = tmp_path / "one.toml"
    path.write_text(ONE_MODE, encoding="utf-8")
    model = load_model(path)
    signals = simulate(model, steps=20, seed=1).signals(model)
    assert FADED_LIKELIHOOD_NOTE not in run_hstf(model, signals, HstfOptions()).notes


@pytest.mark.parametrize(
    ("estimator", "name", "value"), [("imm", "transition_stay", "0.3"), ("hstf", "theta", "0.7")]
)
def test_a_set_option_weighing_modes_is_refused_on_a_one_mode_model(
    tmp_path: Path, estimator: str, name: str, value: str
) -> None:
    path = tmp_path / "one.toml"
    path.write_text(ONE_MODE, encoding="utf-8")
    model, overrides = parse_sets([f"{name}={value}"], path)
    # inert indeed: the run is the same with and without the value
    signals = simulate(model, steps=40, seed=1).signals(model)
    run, options = (run_imm, ImmOptions) if estimator == "imm" else (run_hstf, HstfOptions)
    given = run(model, signals, options(**{name: float(value)}))  # type: ignore[operator]
    default = run(model, signals, options())  # type: ignore[operator]
    np.testing.assert_array_equal(given.state_means, default.state_means)
    np.testing.assert_array_equal(given.state_variances, default.state_variances)
    with pytest.raises(OptionError) as caught:
        prepare_estimators(model, [estimator], overrides)
    assert str(caught.value).startswith(
        f"--set {name}={value}: has no effect on estimator '{estimator}': one_mode has one mode"
    )


def test_an_offline_mode_sequence_is_refused_on_a_one_mode_model(tmp_path: Path) -> None:
    """``--mode-sequence viterbi`` (or ``kbest``, or ``beam``) on a one-mode model ran, and
    the report set a "viterbi" pass beside the filter, every number of both sides the same:
    one mode is the whole sequence, and kbest's one history is the filter's EKF.  Refused
    as ``transition_stay`` is, by the flag, ``--set`` and a model file's key alike."""
    path = tmp_path / "one.toml"
    path.write_text(ONE_MODE, encoding="utf-8")
    model = load_model(path)
    signals = simulate(model, steps=40, seed=1).signals(model)
    # inert indeed: each reading of the sequence gives the filter's modes and states
    filtered = run_imm(model, signals, ImmOptions())
    for sequence in ("viterbi", "kbest"):
        offline = run_imm(model, signals, ImmOptions(mode_sequence=sequence, beam=3))
        np.testing.assert_array_equal(offline.modes, filtered.modes)
        np.testing.assert_allclose(offline.state_means, filtered.state_means, rtol=1e-12)
        np.testing.assert_allclose(offline.state_variances, filtered.state_variances, rtol=1e-12)
    said = "has no effect on estimator 'imm': one_mode has one mode, and its mode sequence"
    for sets, flag, given in [
        ([], "viterbi", "--mode-sequence viterbi"),
        ([], "kbest", "--mode-sequence kbest"),
        (["mode_sequence=viterbi"], None, "--set mode_sequence=viterbi"),
        (["beam=5"], None, "--set beam=5"),
    ]:
        parsed, overrides = parse_sets(sets, path)
        with pytest.raises(OptionError) as caught:
            prepare_estimators(parsed, ["imm"], overrides, mode_sequence=flag)
        assert str(caught.value).startswith(f"{given}: {said}"), caught.value
    # --smooth reads the one mode's RTS smoother: it stays
    parsed, overrides = parse_sets([], path)
    (prepared,) = prepare_estimators(parsed, ["imm"], overrides, smooth=True)
    assert prepared.options.smooth
    for key in ('mode_sequence = "kbest"', "beam = 5"):
        written = tmp_path / "keyed.toml"
        written.write_text(f"{ONE_MODE}\n[estimators.imm]\n{key}\n", encoding="utf-8")
        with pytest.raises(ModelError, match=f"estimators.imm.{key.split()[0]}: .*one mode"):
            resolve_estimator(load_model(written), "imm")
