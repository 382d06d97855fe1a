"""Observer gains from paper 001's LMI (15): the certificate, not particular gains."""

import numpy as np
import pytest

from hybridlog.estimators.lmi import (
    ObserverDesignError,
    certificate,
    observer_gains,
    unobservable_eigenvalues,
)
from hybridlog.estimators.switched_observer import linear_modes
from hybridlog.model.loader import load_model


def _check(A, C, gains, rho):
    """Independent check: ρ² S_i − Ã_iᵀ S_j Ã_i ≻ 0 for all (i, j), S_i ≻ 0, Ã_i Schur."""
    L, S = gains.gains, gains.lyapunov
    closed = A - L @ C
    for i in range(len(A)):
        assert np.linalg.eigvalsh(S[i]).min() > 0
        assert np.abs(np.linalg.eigvals(closed[i])).max() < 1
        for j in range(len(A)):
            gap = rho**2 * S[i] - closed[i].T @ S[j] @ closed[i]
            assert np.linalg.eigvalsh((gap + gap.T) / 2).min() > 0


@pytest.mark.parametrize("name", ["double_cart_case1", "double_cart_case2"])
def test_feasible_and_certified_for_both_cases(name):
    model = load_model(name)
    linear = linear_modes(model)
    gains = observer_gains(linear.A, linear.C, model.mode_ids, model_name=name)
    _check(linear.A, linear.C, gains, 1.0)
    assert gains.margin > 1e-3 and gains.decay_bound < 1.0
    assert np.all(gains.spectral_radii < 1.0)
    # the error of the switched observer shrinks under an arbitrary switching sequence
    rng = np.random.default_rng(0)
    error = rng.normal(size=4)
    closed = linear.A - gains.gains @ linear.C
    values = []
    for _ in range(200):
        q = int(rng.integers(0, 2))
        values.append(error @ gains.lyapunov[q] @ error)
        error = closed[q] @ error
        assert error @ gains.lyapunov[int(rng.integers(0, 2))] @ error >= 0
    assert np.linalg.norm(error) < 1e-4


def test_decay_rate_is_honoured():
    model = load_model("double_cart_case1")
    linear = linear_modes(model)
    gains = observer_gains(linear.A, linear.C, model.mode_ids, decay_rate=0.8)
    _check(linear.A, linear.C, gains, 0.8)
    assert gains.decay_bound <= 0.8 + 1e-9
    margin, bound, _ = certificate(linear.A, linear.C, gains.gains, gains.lyapunov, 0.8)
    assert margin == pytest.approx(gains.margin) and bound == pytest.approx(gains.decay_bound)


def test_undetectable_mode_is_named():
    A = np.array([[[0.5, 0.0], [0.0, 0.4]], [[0.5, 0.0], [0.0, 1.2]]])  # mode b: x2 unstable
    C = np.array([[[1.0, 1.0]], [[1.0, 0.0]]])  # ... and unseen
    with pytest.raises(ObserverDesignError, match=r"mode 'b' is not detectable") as caught:
        observer_gains(A, C, ["a", "b"], model_name="toy")
    assert "eigenvalue 1.2 (|λ| = 1.2) is unobservable" in str(caught.value)
    assert "mode 'a'" not in str(caught.value)


def test_an_infeasible_lmi_says_undetectable_only_of_an_eigenvalue_the_outputs_miss():
    """Which kind of failure a mode's own LMI is: an unseen slow eigenvalue, or the solvers.

    The double cart is observable in both modes; at decay rate 0.01 the solvers find no
    certified gain, and the refusal said "not detectable from the outputs".  One mode alone
    was reported "jointly" infeasible, as a set of modes without a common Lyapunov function.
    """
    linear = linear_modes(load_model("double_cart_case1"))
    with pytest.raises(ObserverDesignError) as caught:
        observer_gains(linear.A, linear.C, ["1", "2"], decay_rate=0.01, model_name="cart")
    message = str(caught.value)
    assert "not detectable" not in message and "admit a gain in theory" in message
    assert "nearer 1" in message
    # one mode whose unseen eigenvalue 0.9 is slower than the decay rate 0.5: undetectable there
    A = np.array([[[0.5, 0.0], [0.0, 0.9]]])
    C = np.array([[[1.0, 0.0]]])
    with pytest.raises(ObserverDesignError) as caught:
        observer_gains(A, C, ["only"], decay_rate=0.5, model_name="toy")
    message = str(caught.value)
    assert "decay rate 0.5: mode 'only' is not detectable at decay rate 0.5" in message
    assert "0.9" in message and "jointly" not in message
    # ... and detectable at 0.95: the unseen 0.9 decays fast enough
    gains = observer_gains(A, C, ["only"], decay_rate=0.95, model_name="toy")
    assert gains.spectral_radii[0] < 0.95


def test_jointly_infeasible_modes_are_named():
    # A rotation seen through x1 in mode p and x2 in mode q: each mode alone admits a
    # dead-beat gain, but switching between them has no certificate at decay rate 0.5.
    A = np.array([[[0.0, 1.0], [-1.0, 0.0]], [[0.0, 1.0], [-1.0, 0.0]]])
    C = np.array([[[1.0, 0.0]], [[0.0, 1.0]]])
    with pytest.raises(ObserverDesignError, match="infeasible for modes 'p', 'q' jointly"):
        observer_gains(A, C, ["p", "q"], decay_rate=0.5, model_name="toy")


def test_bad_decay_rate():
    with pytest.raises(ObserverDesignError, match="decay_rate"):
        observer_gains(np.eye(2)[None], np.ones((1, 1, 2)), ["a"], decay_rate=1.5)


@pytest.mark.parametrize("gain", [1.0, 1e308, 1e-300])
def test_an_output_of_huge_or_tiny_gain_sees_what_it_sees_at_gain_one(gain):
    # y = x1 + 1e308*x2 made the size of [A; C] overflow to inf, so the PBH test called
    # every eigenvalue of the (observable) double cart "unobservable" and analyze said mode
    # '1' is not detectable; y = 1e-300*x1 saw nothing against the tolerance either
    A = np.array(
        [
            [0.7627, 0.4596, 0.1174, 0.02006],
            [-0.8992, 0.7627, 0.4396, 0.1174],
            [0.1174, 0.02006, 0.8801, 0.4797],
            [0.4396, 0.1174, -0.4596, 0.8801],
        ]
    )
    assert unobservable_eigenvalues(A, np.array([[1.0, gain, 0.0, 0.0]])) == []
    assert unobservable_eigenvalues(A, np.array([[gain, 0.0, 0.0, 0.0]])) == []
    assert len(unobservable_eigenvalues(A, np.zeros((1, 4)))) == 4  # no output sees anything
    if gain == 1e308:  # the solvers fail on it: the error says so, and asks for no rate above 1
        with pytest.raises(ObserverDesignError) as refused:
            observer_gains(A[None], np.array([[[1.0, gain, 0.0, 0.0]]]), ["1"], decay_rate=1.0)
        assert "admit a gain in theory" in str(refused.value)
        assert "not detectable" not in str(refused.value) and "nearer 1" not in str(refused.value)


def _unvouched_solutions():
    """Gains and S_i of one stable mode that no certificate may vouch for, by kind."""
    good = np.eye(2)[None]
    return {
        "S negative definite": (np.zeros((1, 2, 1)), -good),
        "S zero": (np.zeros((1, 2, 1)), np.zeros((1, 2, 2))),
        "S NaN": (np.zeros((1, 2, 1)), np.full((1, 2, 2), np.nan)),
        "S infinite": (np.zeros((1, 2, 1)), np.full((1, 2, 2), np.inf)),
        "gain infinite": (np.full((1, 2, 1), np.inf), good),
        "gain NaN": (np.full((1, 2, 1), np.nan), good),
        "products overflow": (np.full((1, 2, 1), 1e200), good),
    }


@pytest.mark.parametrize("kind", list(_unvouched_solutions()))
def test_a_solution_the_numbers_cannot_vouch_for_is_no_certificate(kind, monkeypatch):
    """S_i all negative definite gave margin 1.0 (divided by a negative scale), NaN in S a
    margin inf (min() passed NaN over): both 'certified'; S = 0 raised ZeroDivisionError and
    an infinite gain LinAlgError, 'unexpected' errors."""
    from hybridlog.estimators import lmi

    A = np.array([[[0.5, 0.0], [0.0, 0.5]]])
    C = np.array([[[1.0, 0.0]]])
    gains, lyapunov = _unvouched_solutions()[kind]
    with np.errstate(all="raise"):  # the CLI escalates numerical warnings to errors
        margin, _, _ = certificate(A, C, gains, lyapunov)
    assert margin < 0.0
    monkeypatch.setattr(lmi, "_solve", lambda *args: (gains, lyapunov))
    with pytest.raises(ObserverDesignError, match="'1'"):
        observer_gains(A, C, ["1"])
