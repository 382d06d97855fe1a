"""Reductions to known cases, compared with FilterPy as an independent implementation."""

import numpy as np
import pytest
from filterpy.kalman import ExtendedKalmanFilter, IMMEstimator, KalmanFilter

from hybridlog.estimators.hstf import HstfOptions, run_hstf
from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.model.compiled import compile_model
from hybridlog.model.loader import parse_model
from hybridlog.simulate import simulate
from tests.support.models import LINEAR_TWO_MODE, PENDULUM_ONE_MODE


def _signals(model, steps, seed):
    return simulate(model, steps=steps, seed=seed).signals(model)


def _linear_matrices(model, mode_index):
    """A, B, C of a linear mode, evaluated through the compiled functions."""
    compiled = compile_model(model)
    n, m, nu = model.n_states, model.n_outputs, model.n_inputs
    A = np.zeros((n, n))
    C = np.zeros((m, n))
    compiled.F(mode_index, np.zeros(n), np.zeros(nu), A)
    compiled.H(mode_index, np.zeros(n), np.zeros(nu), C)
    B = np.zeros((n, nu))
    out = np.zeros(n)
    for j in range(nu):
        unit = np.zeros(nu)
        unit[j] = 1.0
        compiled.f(mode_index, np.zeros(n), unit, out)
        B[:, j] = out
    return A, B, C


def kalman_filters(model, kind):
    """One FilterPy Kalman filter (``kind``) per mode of a linear model, at its prior."""
    filters = []
    for index, mode in enumerate(model.modes):
        A, B, C = _linear_matrices(model, index)
        kf = kind(dim_x=model.n_states, dim_z=model.n_outputs, dim_u=model.n_inputs)
        kf.F, kf.B, kf.H = A, B, C
        kf.Q, kf.R = mode.process_noise.copy(), mode.measurement_noise.copy()
        kf.x = model.initial_state.reshape(-1, 1).copy()
        kf.P = model.initial_covariance.copy()
        filters.append(kf)
    return filters


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_imm_equals_filterpy_imm_on_a_linear_two_mode_model(kernel):
    model = parse_model(LINEAR_TWO_MODE)
    signals = _signals(model, steps=500, seed=3)
    result = run_imm(model, signals, ImmOptions(), kernel=kernel)

    filters = kalman_filters(model, KalmanFilter)
    imm = IMMEstimator(filters, model.initial_mode_probabilities.copy(), model.transitions)
    assert signals.n_samples == 501
    for k in range(signals.n_samples - 1):
        imm.predict(signals.inputs[k].reshape(-1, 1))
        imm.update(signals.outputs[k + 1])
        np.testing.assert_allclose(result.state_means[k + 1], imm.x.ravel(), rtol=0, atol=1e-8)
        np.testing.assert_allclose(result.mode_probabilities[k + 1], imm.mu, rtol=0, atol=1e-8)
        np.testing.assert_allclose(np.diag(imm.P), result.state_variances[k + 1], atol=1e-8)
    # The run switched modes, so both filters mattered.
    assert set(result.modes.tolist()) == {0, 1}


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_single_mode_hstf_without_fading_equals_filterpy_ekf(kernel):
    model = parse_model(PENDULUM_ONE_MODE)
    signals = _signals(model, steps=500, seed=11)
    result = run_hstf(model, signals, HstfOptions(fading=False), kernel=kernel)
    compiled = compile_model(model)
    n, m = model.n_states, model.n_outputs

    def jacobian(function, x, u, rows):
        out = np.zeros((rows, n))
        function(0, np.ascontiguousarray(x, dtype=float).ravel(), u, out)
        return out

    def value(function, x, u, rows):
        out = np.zeros(rows)
        function(0, np.ascontiguousarray(x, dtype=float).ravel(), u, out)
        return out

    class Ekf(ExtendedKalmanFilter):
        def predict_x(self, u=0):
            self.x = value(compiled.f, self.x, u, n).reshape(-1, 1)

    ekf = Ekf(dim_x=n, dim_z=m, dim_u=1)
    ekf.x = model.initial_state.reshape(-1, 1).copy()
    ekf.P = model.initial_covariance.copy()
    ekf.Q = model.modes[0].process_noise.copy()
    ekf.R = model.modes[0].measurement_noise.copy()
    for k in range(signals.n_samples - 1):
        u, u_next = signals.inputs[k], signals.inputs[k + 1]
        ekf.F = jacobian(compiled.F, ekf.x, u, n)
        ekf.predict(u=u)
        ekf.update(
            signals.outputs[k + 1].reshape(-1, 1),
            HJacobian=lambda x, u=u_next: jacobian(compiled.H, x, u, m),
            Hx=lambda x, u=u_next: value(compiled.h, x, u, m).reshape(-1, 1),
        )
        np.testing.assert_allclose(result.state_means[k + 1], ekf.x.ravel(), rtol=0, atol=1e-8)
        np.testing.assert_allclose(result.state_variances[k + 1], np.diag(ekf.P), atol=1e-8)
    assert np.all(result.mode_probabilities == 1.0)
