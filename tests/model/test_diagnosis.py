"""What a model's equations say of its estimability, found when it loads (model/diagnosis.py).

Before, ``hybridlog models FILE`` called such models valid without a word, and ``imm``/``hstf``
ran them to finite numbers: the estimates of a state no output sees were the prior's drift
(``x3`` of :data:`UNSEEN` reached 52 against a true 105 with RMSE 18.8 and no warning), and
``hstf`` stopped with an overflow of its variance; ``chiu`` refused "not detectable" only
once it ran; a continuous mode too stiff for its step was found only by ``simulate``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hybridlog.estimators import prepare
from hybridlog.estimators.lmi import observer_gains
from hybridlog.jobs.model_description import check_and_describe
from hybridlog.model.builtins import builtin_names, builtin_text
from hybridlog.model.cache import load_model
from hybridlog.model.diagnosis import MOST_LINES, model_diagnoses
from hybridlog.model.loader import parse_model
from hybridlog.report import build_report, render_markdown
from hybridlog.simulate import simulate


def discrete(states: int, modes: str, tail: str = "", noise: str = "0.01") -> str:
    names = ", ".join(f'"x{i + 1}"' for i in range(states))
    return (
        f'dt = 0.1\nstates = [{names}]\ninputs = ["u"]\noutputs = ["y"]\n'
        f"[noise]\nprocess = {noise}\nmeasurement = 0.01\n"
        f"[initial]\nstate = {[0.0] * states}\ncovariance = 1.0\n"
        '[simulation]\ninputs = { u = "sin(t)" }\n' + modes + tail
    )


UNSEEN = discrete(
    3,
    "[modes.a]\nA = [[0.9, 0, 0], [0, 0.8, 0], [0, 0, 1.02]]\nB = [1.0, 1.0, 0.0]\n"
    "C = [1.0, 0.0, 0.0]\n"
    "[modes.b]\nA = [[0.5, 0, 0], [0, 0.8, 0], [0, 0, 1.02]]\nB = [1.0, 1.0, 0.0]\n"
    "C = [1.0, 0.0, 0.0]\n",
)
"""x2 (stable) and x3 (growing) reach no output in either mode."""


def diagnoses(text: str) -> tuple[str, ...]:
    """What ``models FILE`` says (nonlinear modes linearised)."""
    model = parse_model(text)
    found = model_diagnoses(model)
    # the loader's, which every report's warnings come from: the same but the linearisations
    assert model.diagnoses == tuple(line for line in found if "at [initial] state" not in line)
    return found


def test_states_no_output_determines_are_named_and_a_growing_one_warns() -> None:
    system, modes = diagnoses(UNSEEN)
    assert system == (
        "WARNING: no output determines x2, x3 in any mode nor across switches (the observable "
        "subspace of the modes' A and C leaves them out): their estimates are the model's "
        "prediction from [initial], never corrected by the log, and their RMSE scores that "
        "prediction"
    )
    assert modes.startswith("WARNING: modes 'a', 'b': the outputs do not determine x2, x3 ")
    assert "(the unobservable eigenvalue 1.02)" in modes and "chiu and kmeans refuse" in modes
    # stable, the hidden part decays: a note, not a warning
    assert diagnoses(UNSEEN.replace("1.02]]", "0.7]]")) == (
        system,
        "NOTE: modes 'a', 'b': the outputs do not determine x2, x3 (the observability matrix "
        "of A and C has rank 1 of 3; the part they miss decays in the mode)",
    )
    # coupled into the measured state: observable, nothing to say
    coupled = UNSEEN.replace("A = [[0.9, 0, 0]", "A = [[0.9, 0.1, 0.1]")
    assert diagnoses(coupled.replace("A = [[0.5, 0, 0]", "A = [[0.5, 0.1, 0.1]")) == ()


def test_states_one_mode_misses_and_another_sees_are_said_of_that_mode_only() -> None:
    text = discrete(
        2,
        '[modes.a]\nf = ["0.9*x1", "0.8*x2 + u"]\nh = ["x1"]\n'
        '[modes.b]\nf = ["0.9*x1 + 0.1*x2", "0.8*x2 + u"]\nh = ["x1"]\n',
    )
    assert diagnoses(text) == (
        "NOTE: mode 'a': the outputs do not determine x2 (the observability matrix of A and C "
        "has rank 1 of 2; the part they miss decays in the mode)",
    )


def test_a_mode_whose_outputs_read_no_state_warns() -> None:
    seen = '[modes.a]\nf = ["0.9*x1 + u"]\nh = ["x1"]\n'
    text = discrete(1, seen + '[modes.b]\nf = ["0.5*x1 + u"]\nh = ["u + 1"]\n')
    assert diagnoses(text) == (
        "WARNING: mode 'b': the outputs depend on no state (h reads none of x1): while in it "
        "the log says nothing of the state, whose estimates there are the model's prediction",
    )
    assert diagnoses(text.replace('h = ["u + 1"]', 'h = ["u + x1"]')) == ()


def test_a_nonlinear_model_is_judged_by_structure_and_by_its_linearisation_said_so() -> None:
    text = discrete(
        3,
        '[modes.a]\nf = ["x1 + x1*x2", "0.9*x2 + u", "0.5*x3 + x1**2"]\nh = ["x1**2"]\n',
    )
    structural, linearised = diagnoses(text)
    assert structural.startswith("WARNING: no output determines x3 of the model (no output, ")
    assert linearised == (
        "NOTE: mode 'a': the outputs do not determine x1, x2, x3 to first order at [initial] "
        "state (the observability matrix of the linearisation there, inputs 0, has rank 0 of "
        "3): a filter started there learns of them only as the state moves"
    )
    # away from x1 = 0 the linearisation sees x1 and x2; x3 stays unseen whatever the point
    moved = text.replace("state = [0.0, 0.0, 0.0]", "state = [1.0, 0.0, 0.0]")
    assert diagnoses(moved) == (structural,)


def test_a_slope_beyond_every_float_at_the_initial_state_says_nothing_of_it() -> None:
    """``exp(exp(exp(100*x1)))``'s slope at x1 = 1 overflows mpmath's evaluation itself.

    Before, ``hybridlog models`` died with "unexpected OverflowError in diagnosis.py" (exit 2,
    but called a bug); a slope no float holds is not finite: the linearisation says nothing.
    """
    text = discrete(1, '[modes.a]\nf = ["exp(exp(exp(100*x1)))"]\nh = ["x1"]\n')
    assert diagnoses(text.replace("state = [0.0]", "state = [1.0]")) == ()
    # put into the expression, x1 = 20 made sympy evaluate exp(exp(4.9e8)) exactly: minutes
    text = discrete(
        1, '[modes.a]\nf = ["Piecewise(exp(exp(exp(x1))), x1 > 1e6, x1)"]\nh = ["x1"]\n'
    )
    assert diagnoses(text.replace("state = [0.0]", "state = [20.0]")) == ()


def test_an_undamped_component_without_process_noise_is_noted() -> None:
    rotation = "[modes.a]\nA = [[0.6, -0.8], [0.8, 0.6]]\nB = [0.0, 1.0]\nC = [1.0, 0.0]\n"
    assert diagnoses(discrete(2, rotation, noise="0.0")) == (
        "NOTE: mode 'a': no process noise reaches the undamped eigenvalues 0.6+0.8j, 0.6-0.8j "
        "(|λ| ≈ 1): a filter's variance of that component, and so its gain, tend to 0 while "
        "in the mode, and its estimate stops following the log there",
    )
    assert diagnoses(discrete(2, rotation, noise="[0.0, 0.01]")) == ()
    # outside the unit circle the gain stays positive where the state is observed
    growing = rotation.replace("0.6, -0.8], [0.8, 0.6", "1.05, 0.0], [0.0, 0.5")
    assert diagnoses(discrete(2, growing.replace("C = [1.0, 0.0]", "C = [1.0, 1.0]"))) == ()


CONTINUOUS = """time = "continuous"
dt = 0.01
integration = {method = "rk4", step = 0.001}
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]
[modes.a]
dx = ["-x1 + x2 + u", "-RATE*(x2 - x1)"]
h = ["x1"]
[noise]
measurement = 1e-4
[initial]
state = [0.0, 0.0]
"""


def test_a_continuous_mode_too_stiff_for_the_step_warns() -> None:
    (line,) = diagnoses(CONTINUOUS.replace("RATE", "5000"))
    assert line.startswith(
        "WARNING: mode 'a': integration.step 0.001 s is too long for it: dx has the "
        "eigenvalue λ = -5001 1/s; RK4 multiplies its component by 13.72 a step"
    )
    assert line.endswith("a step of at most 0.000418 s avoids it")
    assert diagnoses(CONTINUOUS.replace("RATE", "500")) == ()


def test_many_findings_are_cut_to_a_count() -> None:
    # 15 modes, each measuring another subset of four uncoupled states of distinct
    # eigenvalues: 14 distinct lines
    subsets = [[float(k >> i & 1) for i in range(4)] for k in range(1, 16)]
    modes = "".join(
        f"[modes.m{k}]\nA = [[0.1, 0, 0, 0], [0, 0.2, 0, 0], [0, 0, 0.3, 0], [0, 0, 0, 0.4]]\n"
        f"B = [1.0, 1.0, 1.0, 1.0]\nC = {c}\n"
        for k, c in enumerate(subsets)
    )
    lines = diagnoses(discrete(4, modes))
    assert len(lines) == MOST_LINES
    assert lines[-1] == "NOTE: 3 more lines of this kind on other modes are not shown"


BUILT_INS = {
    "double_cart_case1": (
        "NOTE: mode '1': no process noise reaches the undamped eigenvalues 0.6901+0.7236j, "
        "0.6901-0.7236j, 0.9527+0.3041j, 0.9527-0.3041j (|λ| ≈ 1): a filter's variance of that "
        "component, and so its gain, tend to 0 while in the mode, and its estimate stops "
        "following the log there",
    ),
    "double_cart_case2": (
        "NOTE: mode '2': the outputs do not determine x3, x4 (the observability matrix of A and "
        "C has rank 3 of 4; the part they miss decays in the mode)",
    ),
}
"""The built-ins' true properties: case 1's mode 1 has no damper (lossless, paper 001's
noise-free example); case 2's printed A_2 (equal entries 0.2417, 0.2918 in columns 3 and 4)
hides x3 - x4 from z1 in mode 2 (its eigenvalue 0.3679 decays).  The others are clean."""


@pytest.mark.parametrize("name", builtin_names())
def test_each_built_in_gets_exactly_its_true_properties(name: str) -> None:
    assert diagnoses(builtin_text(name)) == BUILT_INS.get(name, ())


def test_a_warm_model_keeps_its_diagnoses(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HYBRIDLOG_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "unseen.toml"
    path.write_text(UNSEEN, encoding="utf-8")
    cold, warm = load_model(path), load_model(path)
    assert warm.diagnoses == cold.diagnoses == parse_model(UNSEEN).diagnoses
    # models FILE ends with them
    described = check_and_describe(path).splitlines()
    assert described[-2:] == list(cold.diagnoses)


def test_a_run_s_report_repeats_the_warnings_and_not_the_notes() -> None:
    model = parse_model(UNSEEN)
    log = simulate(model, schedule="a:20,b:20", jit=False)
    signals = log.signals(model)
    result = prepare(model, "imm").run(model, signals)
    report = build_report(
        result, signals, log="run.csv", model_name=model.name, dt=model.dt, model=model
    )
    assert [n for n in report.notes if n in model.diagnoses] == list(model.diagnoses)
    warnings = render_markdown(report).split("## Warnings", 1)[1].split("## Outputs", 1)[0]
    assert "no output determines x2, x3 in any mode" in warnings
    quiet = parse_model(UNSEEN.replace("1.02]]", "0.7]]"))  # a note and a warning
    report = build_report(
        prepare(quiet, "imm").run(quiet, signals),
        signals,
        log="run.csv",
        model_name=quiet.name,
        dt=quiet.dt,
        model=quiet,
    )
    assert [n for n in report.notes if n in quiet.diagnoses] == [quiet.diagnoses[0]]


def test_an_unseen_eigenvalue_just_inside_the_circle_is_not_said_to_be_refused() -> None:
    """|λ| = 0.9999 is "on the boundary" for the warning, but the LMI (15) certifies a gain.

    The warning said "chiu and kmeans refuse the mode" while ``analyze --estimator chiu`` ran
    (certificate margin 2e-4): the warning now says how slowly the observer's error shrinks.
    """
    text = UNSEEN.replace("1.02]]", "0.9999]]")
    modes = diagnoses(text)[-1]
    assert "(the unobservable eigenvalue 0.9999)" in modes
    assert "refuse" not in modes
    assert "chiu's and kmeans' observer error there shrinks by only 0.9999 a sample" in modes
    # and chiu does run it: the LMI (15) is feasible and certified for those modes
    A = np.array(
        [[[0.9, 0, 0], [0, 0.8, 0], [0, 0, 0.9999]], [[0.5, 0, 0], [0, 0.8, 0], [0, 0, 0.9999]]]
    )
    C = np.array([[[1.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]]])
    assert observer_gains(A, C, ("a", "b")).margin > 0
    # at or past 1 the warning still says the mode is refused, as the LMI does
    assert "chiu and kmeans refuse the mode" in diagnoses(UNSEEN.replace("1.02]]", "1.0]]"))[-1]


def test_chiu_and_kmeans_refuse_an_undetectable_mode_before_any_log_is_read(tmp_path: Path) -> None:
    """An unseen eigenvalue of size >= 1 leaves the LMI (15) no gain, whatever the log.

    ``analyze --estimator chiu`` read and clustered the whole log before the LMI refused the
    model, and ``hybridlog models FILE`` listed chiu and kmeans among its estimators in the
    line above its own warning that they refuse the mode.  Just inside the circle (0.9999)
    the LMI has a gain and both still run.
    """
    from hybridlog.errors import ModelError

    for size in ("1.02", "1.0"):
        model = parse_model(UNSEEN.replace("1.02]]", f"{size}]]"))
        for name in ("chiu", "kmeans"):
            with pytest.raises(ModelError, match=r"needs every mode detectable") as refused:
                prepare(model, name)
            assert f"mode 'a' has the eigenvalue {size.rstrip('0').rstrip('.')}" in str(
                refused.value
            )
    path = tmp_path / "unseen.toml"
    path.write_text(UNSEEN, encoding="utf-8")
    listed = [line for line in check_and_describe(path).splitlines() if "estimators for" in line]
    assert listed == ["estimators for it: hstf, imm"]
    inside = parse_model(UNSEEN.replace("1.02]]", "0.9999]]"))
    for name in ("chiu", "kmeans"):
        prepare(inside, name)
