"""A components model (paper 002 eq. (2) with further modes) and logs simulated from it.

Used by the ``unknown-mode`` tests and the estimator contract.  The simulation is the
example's equations written out by hand (eq. (3) with the modes' variants), independent of
the estimator's structural analysis.
"""

import numpy as np

from hybridlog.signals import AlignedSignals

# Paper 002 eq. (2) plus m12 (A1's input stage off: w_c1 = 0) and m22 (a slower x_c1).
# Leaving the unknown mode is likely (0.5 per step): staying unknown must cost more per step
# than a known mode's expected log P_O (-1/2 per output), or unknown wins by default.
CPHA_EXAMPLE = """
name = "cpha_example"
reference = "Hofbaur, Williams (paper 002), eqs. (2)-(3)"
dt = 1.0
states = ["xc1", "xc2", "xc3"]
inputs = ["uc1"]
outputs = ["yc1", "yc2"]
variables = ["wc1"]

[noise]
process = [0.01, 0.01, 0.01]
measurement = [0.01, 0.01]

[initial]
state = [0.0, 0.0, 0.0]
covariance = 1.0

[components.A1]
unknown = 0.001
initial = "m11"

[components.A1.modes.m11]
equations = ["uc1 = 5.0*wc1"]

[components.A1.modes.m12]
equations = ["wc1 = 0"]

[[components.A1.transitions]]
from = "*"
to = {m11 = 0.01, m12 = 0.01}

[[components.A1.transitions]]
from = "unknown"
to = {m11 = 0.25, m12 = 0.25}

[components.A2]
unknown = 0.001
initial = "m21"

[components.A2.modes.m21]
equations = ["xc1[k] = 0.8*xc1[k-1] + wc1[k-1]", "yc1 = xc1"]

[components.A2.modes.m22]
equations = ["xc1[k] = 0.5*xc1[k-1] + wc1[k-1]", "yc1 = xc1"]

[[components.A2.transitions]]
from = "*"
to = {m21 = 0.01, m22 = 0.01}

[[components.A2.transitions]]
from = "unknown"
to = {m21 = 0.25, m22 = 0.25}

[components.A3]
unknown = 0.001
initial = "m31"

[components.A3.modes.m31]
equations = [
  "xc2[k] = xc3[k-1] + yc1[k-1]",
  "xc3[k] = 0.4*xc2[k-1] + 0.5*uc1[k-1]",
  "yc2 = 2.0*xc2 + xc3",
]

[[components.A3.transitions]]
from = "unknown"
to = {m31 = 0.5}
"""


def cpha_log(model, n, seed, *, a1=None, a2=None):
    """Simulate ``CPHA_EXAMPLE``: ``a1(k)``/``a2(k)`` give A1's/A2's mode at step k.

    A1's mode may also be ``"drift"``: w_c1 = u_c1/5 + 0.02 k (a behaviour no mode models).
    Noise: the model's variances.  Returns the aligned signals.
    """
    rng = np.random.default_rng(seed)
    u = 1.0 + 0.5 * np.sin(np.arange(n) / 9.0)
    x = np.zeros(3)
    sd_q, sd_r = 0.1, 0.1
    ys = []
    for k in range(n):
        if k > 0:
            m1 = a1(k - 1) if a1 else "m11"
            m2 = a2(k) if a2 else "m21"
            w = {"m11": u[k - 1] / 5.0, "m12": 0.0, "drift": u[k - 1] / 5.0 + 0.02 * k}[m1]
            decay = {"m21": 0.8, "m22": 0.5}[m2]
            x = np.array([decay * x[0] + w, x[2] + x[0], 0.4 * x[1] + 0.5 * u[k - 1]])
            x = x + rng.normal(0.0, sd_q, 3)
        y = np.array([x[0], 2.0 * x[1] + x[2]]) + rng.normal(0.0, sd_r, 2)
        ys.append(y)
    return AlignedSignals(
        "simulation",
        np.arange(n, dtype=np.float64) * model.dt,
        model.inputs,
        model.outputs,
        u[:, None].copy(),
        np.array(ys),
    )


TRUTH_STEPS = 180
"""Samples of :func:`cpha_truth_log`."""


def _a2_switching(k):
    """A2's true mode: m22 on steps 60..119, else m21."""
    return "m22" if 60 <= k < 120 else "m21"


def cpha_truth_log(root, *, joint_mode=False):
    """``CPHA_EXAMPLE`` as a model file and a CSV log of it with every component's true mode.

    A1 in m11, A2 in m22 on steps 60..119 (else m21), A3 in m31, over :data:`TRUTH_STEPS`
    samples, in columns ``mode.A1``..``mode.A3``; ``joint_mode`` adds the joint labels as a
    ``mode`` column (``m11|m21|m31``).  Returns ``(model file, log)``.
    """
    from hybridlog.io.writers import write_table
    from hybridlog.model.loader import load_model

    model_file = root / "cpha.toml"
    model_file.write_text(CPHA_EXAMPLE)
    n = TRUTH_STEPS
    signals = cpha_log(load_model(model_file), n, seed=3, a2=_a2_switching)
    truth = {
        "mode.A1": ["m11"] * n,
        "mode.A2": [_a2_switching(k) for k in range(n)],
        "mode.A3": ["m31"] * n,
    }
    if joint_mode:
        truth["mode"] = ["|".join(labels) for labels in zip(*truth.values(), strict=True)]
    columns = {
        "t": signals.time,
        "uc1": signals.inputs[:, 0],
        "yc1": signals.outputs[:, 0],
        "yc2": signals.outputs[:, 1],
        **truth,
    }
    return model_file, write_table(root / "log.csv", columns)
