"""The filter cluster of paper 002 against the single MIMO EKF of eq. (3) (Appendix A)."""

import numpy as np
import pytest

from hybridlog.estimators.cpha.cluster_filter import FilterCache, compile_cluster
from hybridlog.estimators.cpha.hypotheses import Hypothesis, Tracker
from hybridlog.estimators.cpha.structure import StructureCache
from hybridlog.model.loader import parse_model
from tests.estimators.test_cpha_structure import PAPER_EXAMPLE

FULL = ("m11", "m21", "m31")
# eq. (3): x(k) = A x(k-1) + B u(k-1), y(k) = C x(k)
A = np.array([[0.8, 0.0, 0.0], [1.0, 0.0, 1.0], [0.0, 0.4, 0.0]])
B = np.array([[0.2], [0.0], [0.5]])
C = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, 1.0]])


def mimo_ekf(x0, P0, Q, R, u, y):
    """The MIMO filter of Fig. 2: eqs. (12)-(20) on the whole model (3)."""
    x, P = x0.copy(), P0.copy()
    out = [x.copy()]
    for k in range(1, len(y)):
        x = A @ x + B @ u[k - 1]
        P = A @ P @ A.T + Q
        S = C @ P @ C.T + R
        K = P @ C.T @ np.linalg.inv(S)
        x = x + K @ (y[k] - C @ x)
        P = (np.eye(3) - K @ C) @ P
        out.append(x.copy())
    return np.array(out)


def simulate(n, r1, seed):
    rng = np.random.default_rng(seed)
    u = (1.0 + np.sin(np.arange(n) / 7.0))[:, None]
    x = np.zeros(3)
    y = [C @ x]
    for k in range(1, n):
        x = A @ x + B @ u[k - 1] + rng.normal(0.0, 0.1, 3)
        y.append(C @ x + rng.normal(0.0, [np.sqrt(r1), 0.2]))
    return u, np.array(y)


def cluster_run(model, u, y):
    names = {"states": model.states, "inputs": model.inputs, "outputs": model.outputs}
    tracker = Tracker(
        model.components,
        StructureCache(model.components, variables=model.variables, **names),
        FilterCache(**names),
        u,
        y,
        beam=1,
        candidates=1,
        variance_growth=1.1,
        unknown_mode=False,
    )
    h = Hypothesis(
        FULL, 0.0, model.initial_state.copy(), model.initial_covariance.copy(), y[0] * np.nan
    )
    means, log_po = [h.x.copy()], []
    for k in range(1, len(y)):
        h = tracker.successor(h, FULL, k)
        means.append(h.x.copy())
        log_po.append(h.log_belief)
    return np.array(means), np.array(log_po), tracker


def example(r1, p0_xc1):
    text = PAPER_EXAMPLE.replace("measurement = [0.5, 0.05]", f"measurement = [{r1}, 0.04]")
    text = text.replace("covariance = 1.0", f"covariance = [{p0_xc1}, 1.0, 1.0]")
    return parse_model(text)


def test_with_y_c1_exact_the_filter_cluster_is_the_mimo_ekf():
    # The filters are equal when the virtual input carries what the MIMO filter knows of
    # x_c1: y_c1 measured without noise (r_1 = 0, so eq. (6) adds nothing) and x_c1(0) known
    # (zero prior variance, no prior correlation).  Then MIMO's x̂_c1(k|k) = y_c1(k) and its
    # covariance is block diagonal, so the two filters do the same arithmetic.
    model = example(0.0, 0.0)
    u, y = simulate(60, 0.0, seed=3)
    means, _, _ = cluster_run(model, u, y)
    Q = np.diag([0.01, 0.02, 0.03])
    R = np.diag([0.0, 0.04])
    expected = mimo_ekf(np.zeros(3), np.diag([0.0, 1.0, 1.0]), Q, R, u, y)
    np.testing.assert_allclose(means, expected, rtol=0, atol=1e-10)


def test_with_a_noisy_virtual_input_the_two_filters_differ():
    # With r_1 > 0 the cluster replaces x_c1 by its noisy measurement (eq. (6) widens Q̃_3)
    # while the MIMO filter uses its estimate, and MIMO's x_c1 also learns from y_c2
    # (x_c2(k) = x_c1(k-1) + ...): the filters are not equal.
    model = example(0.04, 1.0)
    u, y = simulate(60, 0.04, seed=3)
    means, _, _ = cluster_run(model, u, y)
    expected = mimo_ekf(
        np.zeros(3), np.eye(3), np.diag([0.01, 0.02, 0.03]), np.diag([0.04, 0.04]), u, y
    )
    assert np.all(np.abs(means - expected).max(axis=0) > 1e-3)


def test_p_o_is_the_product_of_the_clusters_and_at_most_1():
    model = example(0.04, 1.0)
    u, y = simulate(30, 0.04, seed=5)
    _, log_po, tracker = cluster_run(model, u, y)
    assert np.all(log_po <= 0.0) and np.all(np.isfinite(log_po))
    # eq. (7): the joint P_O is the product of the filters' P_O (sum of logs) ...
    decomposition = tracker.structure.get(FULL)
    filters = [tracker.filters.get(c) for c in decomposition.clusters]
    x0, P0 = model.initial_state, model.initial_covariance
    parts = [
        f.step(x0[f.states], P0[np.ix_(f.states, f.states)], u[0], y[0], u[1], y[1]).log_po
        for f in filters
    ]
    assert log_po[0] == pytest.approx(sum(parts), abs=1e-12)
    # ... and a component in the unknown mode drops its filter (the upper bound of §3).
    h = Hypothesis(FULL, 0.0, x0.copy(), P0.copy(), y[0] * np.nan)
    unknown = tracker.successor(h, ("unknown", "m21", "m31"), 1)
    assert unknown.log_belief == pytest.approx(parts[1], abs=1e-12)
    assert unknown.log_belief >= log_po[0]


def test_held_states_keep_their_mean_and_grow_their_variance():
    model = example(0.04, 1.0)
    u, y = simulate(10, 0.04, seed=7)
    _, _, tracker = cluster_run(model, u, y)
    x0 = np.array([0.3, 0.0, 0.0])
    h = Hypothesis(("unknown", "m21", "m31"), 0.0, x0, np.eye(3) * 2.0, y[0] * np.nan)
    for k in range(1, 4):
        h = tracker.successor(h, ("unknown", "m21", "m31"), k)
    assert h.x[0] == 0.3 and h.P[0, 0] == pytest.approx(2.0 * 1.1**3)
    assert h.P[0, 1] == h.P[0, 2] == 0.0
    assert np.isnan(h.y_pred[0]) and np.isfinite(h.y_pred[1])


def test_the_unrolled_ekf_is_the_numpy_ekf():
    text = PAPER_EXAMPLE.replace("0.8*xc1[k-1]", "0.8*sin(xc1[k-1])").replace(
        '"yc2 = 2.0*xc2 + xc3"', '"yc2 = 2.0*xc2 + exp(xc3/4)"'
    )
    model = parse_model(text)
    names = {"states": model.states, "inputs": model.inputs, "outputs": model.outputs}
    structure = StructureCache(model.components, variables=model.variables, **names)
    rng = np.random.default_rng(0)
    for cluster in structure.get(FULL).clusters:
        fast = compile_cluster(cluster, **names)
        slow = compile_cluster(cluster, **names, unrolled=False)
        assert fast._ekf is not None and slow._ekf is None
        n = len(cluster.states)
        for _ in range(5):
            x = rng.normal(size=n)
            L = rng.normal(size=(n, n))
            P = L @ L.T + np.eye(n)
            u0, u1, y0, y1 = rng.normal(size=1), rng.normal(size=1), *rng.normal(size=(2, 2))
            a = fast.step(x, P, u0, y0, u1, y1)
            b = slow.step(x, P, u0, y0, u1, y1)
            np.testing.assert_allclose(a.x, b.x, rtol=1e-10, atol=1e-12)
            np.testing.assert_allclose(a.P, b.P, rtol=1e-10, atol=1e-12)
            np.testing.assert_allclose(a.y_pred, b.y_pred, rtol=1e-12)
            assert a.log_po == pytest.approx(b.log_po, rel=1e-10)
