"""Process pools whose failures reach the user as one line.

An error a worker raises comes back through its future and is re-raised here as it is (an
:class:`~acc_fusion.core.errors.AccFusionError` stays one line).  Two failures need more: a
worker that dies without raising (libsumo crashes on some malformed networks) breaks the pool
with a ``BrokenProcessPool`` traceback, turned here into one sentence naming what the worker
ran; and a pool left at once after an error (``shutdown(wait=False)``) has its workers finish
their runs for nothing and, with ``max_tasks_per_child``, its manager thread fail with an
"Exception in thread" traceback (CPython gh-115634), so :func:`stop` ends the workers and
then waits for the pool.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager

from acc_fusion.core.errors import AccFusionError


def died(what: str) -> AccFusionError:
    """The error of a worker process running ``what`` that ended without raising."""
    return AccFusionError(
        f"the process running {what} ended abruptly, without an error message (SUMO does so "
        "on some malformed network or route files; check them with `sumo -c FILE`)"
    )


def stop(pool: ProcessPoolExecutor) -> None:
    """Shut ``pool`` down now: its workers terminated (a running job is not finished for
    nothing), the jobs not started cancelled, and the pool's threads joined."""
    for process in list((pool._processes or {}).values()):  # no public way before 3.14
        process.terminate()
    pool.shutdown(wait=True, cancel_futures=True)


@contextmanager
def process_pool(what: str, workers: int, **kw) -> Iterator[ProcessPoolExecutor]:
    """A pool of ``workers`` spawned processes running ``what`` (words for a message): left
    normally, it waits for its jobs; left by an error, it is stopped at once (:func:`stop`),
    and a worker that died is :func:`died`'s one sentence.  ``kw`` goes to
    :class:`~concurrent.futures.ProcessPoolExecutor`."""
    pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"), **kw)
    try:
        yield pool
    except BrokenProcessPool:
        stop(pool)
        raise died(what) from None
    except BaseException:
        stop(pool)
        raise
    pool.shutdown(wait=True)
