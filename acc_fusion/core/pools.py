"""Process pools whose failures reach the user as one line.

An error a worker raises comes back through its future and is re-raised here as it is (an
:class:`~acc_fusion.core.errors.AccFusionError` stays one line).  Two failures need more: a
worker that dies without raising (libsumo crashes on some malformed networks) breaks the pool
with a ``BrokenProcessPool`` traceback, turned here into one sentence naming what the worker
ran; and a pool left at once after an error (``shutdown(wait=False)``) has its workers finish
their runs for nothing and, with ``max_tasks_per_child``, its manager thread fail with an
"Exception in thread" traceback (CPython gh-115634), so :func:`stop` ends the workers and
then waits for the pool.  And a worker outlives nothing: it exits by itself when the process
that made its pool is gone, even after SIGTERM or SIGKILL (:func:`watch_parent`), instead of
running its simulation to the end for no one.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
from collections.abc import Callable, Iterator
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


def watch_parent(parent: int) -> None:
    """In a worker: exit as soon as the process ``parent`` that made it is gone (checked every
    0.5 s by a daemon thread)."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def _start_worker(parent: int, initializer: Callable | None, initargs: tuple) -> None:
    """A :func:`process_pool` worker's initializer: :func:`watch_parent`, then the pool's."""
    watch_parent(parent)
    if initializer is not None:
        initializer(*initargs)


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
    :class:`~concurrent.futures.ProcessPoolExecutor`; its workers exit with this process
    (:func:`watch_parent`)."""
    start = (os.getpid(), kw.pop("initializer", None), kw.pop("initargs", ()))
    pool = ProcessPoolExecutor(
        workers, mp_context=multiprocessing.get_context("spawn"), initializer=_start_worker,
        initargs=start, **kw,
    )  # fmt: skip
    try:
        yield pool
    except BrokenProcessPool:
        stop(pool)
        raise died(what) from None
    except BaseException:
        stop(pool)
        raise
    pool.shutdown(wait=True)
