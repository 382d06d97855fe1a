"""The warm-up every batch worker needs, done once by importing this module in the forkserver.

:class:`hybridlog.jobs.workers.WorkerPool` forks its workers from a forkserver, a fresh
interpreter that imports this module (multiprocessing's preload) before it forks any: each
worker starts with numpy, numba with its CPU target set up (:func:`hybridlog.jit.set_up`,
about 0.3 s of Python) and the modules of :data:`MODULES` imported, instead of paying for
them itself.  The forkserver warms up while the batch process imports and checks its inputs.

Unlike every other module, importing this one does work (it compiles numba's one-line
set-up function), so nothing but the forkserver imports it.  It must leave the forkserver
with no thread but its main one at fork time: so no polars, nor any module that imports it
(the table readers, ``report/``'s writers and tables), since importing polars starts threads
that no fork handler stops; numpy's and scipy's OpenBLAS pools are stopped by their own
fork handler (what was measured: :mod:`hybridlog.jobs.workers`).
"""

from __future__ import annotations

import gc
import importlib
import signal

from hybridlog import jit

__all__ = ["MODULES"]

MODULES = (
    "hybridlog.estimators.hstf",
    "hybridlog.estimators.imm",
    "hybridlog.io.load",
    "hybridlog.jobs.batch_task",
    "hybridlog.model.cache",
    "hybridlog.report.build",
)
"""What a batch worker's first log imports, less what imports polars: the model loader, the
filters and their compiled loops' machinery, reading and aligning, the report's contents,
the task of a log (which imports no polars: the batch process imports it too).  Not
:mod:`hybridlog.jobs.batch`, whose planning, summaries and JUnit modules only the batch
process runs (0.01 s of the warm-up, which every batch of ``--jobs N`` waits for)."""

# Ctrl-C reaches every process of the terminal's group; the batch process decides and stops
# its workers (hybridlog.jobs.workers).  Blocked, not only ignored: a library imported
# later may install a SIGINT handler of its own (polars does, hybridlog.polars_import takes
# it back, but only in the main thread); a blocked signal reaches no handler, and a fork
# (every worker) and each thread started after it keep the mask.  Before the imports, so
# that the warm-up is not cut short either.
signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
# No collection meanwhile: the imports make some 110,000 objects that live as long as the
# process, which the collector walked in 270 passes as they grew (two of them over all),
# freeing 1,100 objects (0.5 MB, then frozen with the rest).  Without them the warm-up took
# 0.49-0.52 s of CPU, with them 0.57-0.60 s (three runs each, on a machine shared with other
# work): every batch of --jobs N waits for it before its first log.
gc.disable()
for module in MODULES:
    importlib.import_module(module)
jit.set_up()
# The objects of these imports are never walked by a collector again: not by the workers'
# (whose walks would also write to, and so copy, the pages they share with the forkserver)
# nor by the forkserver's tear-down, which ends 0.12 s sooner (a caller reading the batch's
# output through a pipe waits for it: the forkserver holds the batch's stdout and stderr).
gc.freeze()
gc.enable()  # the workers collect the garbage of their logs (hybridlog.jobs.workers)
