"""What the logs of a batch share: :class:`BatchJob`, sent with each log to its worker.

It holds the run's options and the hashes of what the batch reads, and
:meth:`BatchJob.provenance` is what a report of one log made in this run records (key
``batch``), which a resumed batch compares; :data:`PLOT_CHOICES` are ``--plots``' values.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

from hybridlog import __version__
from hybridlog.io import ReadOptions
from hybridlog.jit import package_fingerprint
from hybridlog.jobs.provenance import library_versions

__all__ = ["PLOT_CHOICES", "BatchJob"]


PLOT_CHOICES = ("none", "failed", "all")
"""``--plots``: no per-log plots (the default in batch), logs that miss a gate, every log."""


@dataclass(frozen=True)
class BatchJob:
    """Everything the logs of a batch share; sent with each log to the worker analysing it.

    Attributes
    ----------
    model_ref, model_sha256, model_name, sets, estimator:
        The model (file path or built-in name), its content hash and name, the ``--set``
        values and the estimator's registry name.
    read, table_format, fail_under, fail_over, plots, force:
        The run's options (``plots``: one of :data:`PLOT_CHOICES`).
    smooth, mode_sequence:
        ``--smooth`` and ``--mode-sequence`` (estimator options: recorded in ``settings``).
    offline:
        Whether the estimator's options ask for an offline pass
        (:attr:`~hybridlog.estimators.Prepared.offline`, also from ``--set`` or the model
        file): the summaries then show the filter's own metrics beside the offline ones.
    settings:
        The settings that change results, as canonical JSON (part of :func:`provenance`).
    msg_dir_stamps:
        What ``stat`` said of each ``--msg-dir`` before it was hashed into ``settings``.
    """

    model_ref: str
    model_sha256: str
    model_name: str
    sets: tuple[str, ...]
    estimator: str
    read: ReadOptions
    table_format: str
    fail_under: tuple[str, ...]
    fail_over: tuple[str, ...]
    plots: str
    force: bool
    settings: str
    smooth: bool = False
    mode_sequence: str | None = None
    offline: bool = False
    msg_dir_stamps: tuple[str, ...] = ()
    """:func:`~hybridlog.jobs.provenance.folder_stamp` of each ``--msg-dir`` when the batch
    hashed them: each log checks them cheaply
    (:func:`~hybridlog.jobs.batch_task._check_unchanged`)."""
    run: str = ""
    """This run of the batch (a random token), recorded beside the provenance (key
    ``batch.run``) and not compared by a later run: a log's task that Dask ran a second
    time, its first result lost with a worker that died before the client collected it,
    finds the report its first run wrote, and the log is ``done``, as it is without Dask,
    not ``skipped`` (:func:`~hybridlog.jobs.batch_task._reusable`)."""

    def provenance(self, log_sha256: str) -> dict[str, Any]:
        """What a report of this batch for a log of this content records (key ``batch``).

        The key also holds :attr:`run`, which a later run does not compare.
        """
        return {
            "log_sha256": log_sha256,
            "model_sha256": self.model_sha256,
            "settings": json.loads(self.settings),
            "hybridlog_version": __version__,
            # the code that made the numbers: an edit of an estimator (a development install,
            # a patched build) keeps the version but not the results
            "hybridlog_code": package_fingerprint(),
            "libraries": library_versions(),
        }
