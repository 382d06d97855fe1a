"""A plain NumPy transcription of the HSTF (paper 000, eqs. (10)-(40)), for tests only.

It shares nothing with the package's compiled path but the parsed model: the mode functions
and Jacobians are built here with ``sympy.lambdify`` and every matrix step is a NumPy call.
"""

import numpy as np
import sympy
from scipy.stats import multivariate_normal

# ∂sign/∂x = 0 and ∂max(x, 0)/∂x = 1 above 0, 1/2 at 0: the conventions the package documents.
_DERIVATIVE_CONVENTIONS = {
    "DiracDelta": lambda x: 0.0,
    "Heaviside": lambda x: np.heaviside(x, 0.5),
}


def mode_functions(model):
    xs, us = model.symbols()
    functions = []
    for mode in model.modes:
        f = sympy.Matrix(mode.f)
        h = sympy.Matrix(mode.h)
        functions.append(
            tuple(
                sympy.lambdify((xs, us), expr, modules=[_DERIVATIVE_CONVENTIONS, "numpy"])
                for expr in (f, f.jacobian(xs), h, h.jacobian(xs))
            )
        )
    return functions


@np.errstate(invalid="ignore")  # np.select evaluates sqrt(x2) on both branches of Piecewise
def reference_hstf(model, inputs, outputs, *, rho, beta, theta, fading=True, unfaded=False):
    functions = mode_functions(model)
    n_q = model.n_modes
    Q = [m.process_noise for m in model.modes]
    R = [m.measurement_noise for m in model.modes]
    x = model.initial_state.copy()
    P = model.initial_covariance.copy()
    mu = model.initial_mode_probabilities.copy()
    q_hat = int(np.argmax(mu))
    S = None
    means, probabilities, modes = [x.copy()], [mu.copy()], [q_hat]
    for k in range(outputs.shape[0] - 1):
        u, u_next, y = inputs[k], inputs[k + 1], outputs[k + 1]
        x_i = [np.asarray(fn[0](x, u), float).ravel() for fn in functions]  # (10)
        F_i = [np.asarray(fn[1](x, u), float) for fn in functions]  # (25)
        x_pred = sum(x_i) / n_q  # (21)
        H_i = [np.asarray(fn[3](x_pred, u_next), float) for fn in functions]  # (12)
        y_i = [np.asarray(fn[2](x_i[i], u_next), float).ravel() for i, fn in enumerate(functions)]
        gamma = [y - y_i[i] for i in range(n_q)]  # (31)
        P_i_pred, unfaded_pred = [], []
        for i in range(n_q):
            FPF = F_i[i] @ P @ F_i[i].T
            lam = 1.0
            if fading:
                M = H_i[i] @ FPF @ H_i[i].T  # (28)
                outer = np.outer(gamma[i], gamma[i])
                V = outer if k == 0 else (rho * S + outer) / (1 + rho)  # (30)
                N = V - H_i[i] @ Q[i] @ H_i[i].T - beta * R[i]  # (29)
                lam0 = np.trace(N) / np.trace(M)  # (27)
                lam = lam0 if lam0 >= 1 else 1.0  # (26)
            P_i_pred.append(lam * FPF + Q[i])  # (24)
            unfaded_pred.append(FPF + Q[i])
        P_pred = (
            sum(P_i_pred[i] + np.outer(x_i[i] - x_pred, x_i[i] - x_pred) for i in range(n_q)) / n_q
        )  # (22)
        x_post, P_post, S_i, likelihood = [], [], [], []
        for i in range(n_q):
            H = H_i[i]
            K = P_pred @ H.T @ np.linalg.inv(H @ P_pred @ H.T + R[i])  # (11)
            x_post.append(x_i[i] + K @ gamma[i])  # (9)
            P_post.append((np.eye(len(x)) - K @ H) @ P_pred)  # (32)
            base = unfaded_pred[i] if unfaded else P_i_pred[i]
            S_i.append(H @ base @ H.T + R[i])  # (35)
            likelihood.append(multivariate_normal(mean=np.zeros(len(y)), cov=S_i[i]).pdf(gamma[i]))
        weights = np.array(likelihood) / n_q
        mu = weights / weights.sum()  # (33)
        x = sum(mu[i] * x_post[i] for i in range(n_q))  # (36)
        P = sum(
            mu[i] * (P_post[i] + np.outer(x_post[i] - x, x_post[i] - x)) for i in range(n_q)
        )  # (37)
        y_hat = sum(mu[i] * y_i[i] for i in range(n_q))  # (39)
        S = sum(
            mu[i] * (S_i[i] + np.outer(y_i[i] - y_hat, y_i[i] - y_hat)) for i in range(n_q)
        )  # (38)
        best = int(np.argmax(mu))
        if mu[best] >= theta:  # (40)
            q_hat = best
        means.append(x.copy())
        probabilities.append(mu.copy())
        modes.append(q_hat)
    return np.array(means), np.array(probabilities), np.array(modes)
