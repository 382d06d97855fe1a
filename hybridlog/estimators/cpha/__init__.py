"""The ``unknown-mode`` estimator (paper 002): concurrent probabilistic hybrid automata.

``structure`` — causal ordering, SCCs, slicing, observability/determination, clusters;
``cluster_filter`` — an EKF per cluster; ``hypotheses`` — k-best hybrid estimation;
``unknown_mode`` — the estimator.
"""
