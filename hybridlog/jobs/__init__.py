"""The jobs the commands run: the only layer that reads logs and models and writes outputs.

- :mod:`~hybridlog.jobs.analysis`: ``analyze`` (one log, one estimator, one report folder),
  and :mod:`~hybridlog.jobs.compare`: ``compare`` (one log, several estimators, a
  side-by-side table); the steps they share with ``batch`` are
  :mod:`~hybridlog.jobs.overrides` (``--set``, ``--smooth``, ``--mode-sequence`` and the
  estimators prepared), :mod:`~hybridlog.jobs.gate_checks` (the CI gates checked) and
  :mod:`~hybridlog.jobs.estimation` (the inputs, the log read and checked, the estimators run).
- :mod:`~hybridlog.jobs.batch`: many logs, one report folder each, a summary; its parts are
  the ``batch_*`` modules, its worker processes are in :mod:`~hybridlog.jobs.workers`.
- :mod:`~hybridlog.jobs.cluster`: ``hybridlog cluster``, the mode classifier of paper 001
  fitted on one log and saved as ``centers.json`` with a picture
  (:mod:`~hybridlog.jobs.cluster_plot`); :mod:`~hybridlog.jobs.centers` reads and writes
  that file (also for the ``centers=FILE`` option of ``chiu`` and ``kmeans``).
- :mod:`~hybridlog.jobs.simulate`: ``hybridlog simulate``, a simulated run written as a log.

Each job checks everything the user gave before it reads a log or writes a byte, calls the
pure algorithms below it (:mod:`hybridlog.io`, :mod:`hybridlog.model`,
:mod:`hybridlog.cluster`, :mod:`hybridlog.estimators`, :mod:`hybridlog.simulate`) and writes
through :mod:`hybridlog.report` and :mod:`hybridlog.outputs`.  Jobs print nothing; every
failure the user can fix is a :class:`~hybridlog.errors.HybridlogError`.  Importing this
package imports none of its modules.
"""
