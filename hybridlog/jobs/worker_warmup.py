"""The warm-up every batch worker needs, done once by importing this module in the forkserver.

:class:`hybridlog.jobs.workers.WorkerPool` starts its workers from a forkserver, a fresh
interpreter that imports this module (multiprocessing's preload) and then forks one worker
per request: each worker starts with numpy, numba with its CPU target set up
(:func:`hybridlog.jit.set_up`, 0.3-0.5 s of Python), the model loader and the filters'
machinery already imported, instead of paying for them itself.  The forkserver warms up in
parallel with the batch process, which meanwhile checks the inputs.

Unlike every other module, importing this one does work (it compiles numba's one-line
set-up function): it is imported only by the forkserver.  It must leave that process with
no thread of its own when it forks (a thread holding a lock at fork time leaves the lock
held forever in the child):

- polars is not imported (nor any hybridlog module that imports it: the readers of tables,
  ``report/``, ``jobs/``): importing polars starts two jemalloc background threads and the
  ``polars-ooc-cleaner`` and ``polars-ooc-decay`` threads, whose state a forked child
  would inherit half-copied.  Each worker imports polars after the fork (~0.08 s).
- numpy's OpenBLAS and scipy's (loaded by numba's set-up for its linear algebra) each start
  a thread pool at import; OpenBLAS stops its pool in a ``pthread_atfork`` handler before
  every fork and restarts it on first use, so the forkserver has only its main thread when
  it forks (``tests/jobs/test_workers.py`` reads ``/proc/<forkserver>/task``).
"""

from __future__ import annotations

# imported for the workers forked from this process, not used here
import hybridlog.estimators.hstf  # noqa: F401
import hybridlog.estimators.imm  # noqa: F401
import hybridlog.io.load  # noqa: F401
import hybridlog.model.cache  # noqa: F401
import hybridlog.report.build  # noqa: F401
from hybridlog import jit

__all__: list[str] = []

jit.set_up()
