"""Executors: where parallel runs go, a sweep's chunks (:mod:`acc_fusion.sweep.run`) and the
runs of a many-seed SUMO study (:mod:`acc_fusion.sweep.seeds`).

:func:`make_map` checks the settings once and returns a map of any picklable function over a
list of items, yielding ``(item, result)`` as each finishes (:func:`local_map`,
:func:`ray_map`); :func:`make_executor` is that map over a sweep's chunks.

An executor takes the chunks still to run and yields ``(chunk, columns)`` as each finishes,
in any order; the sweep stores every chunk's rows as it arrives.  A chunk's rows depend only
on the chunk (:func:`acc_fusion.sweep.chunks.run_chunk`), so every executor gives the same rows.

``local`` (default)
    A pool of ``workers`` processes (:class:`concurrent.futures.ProcessPoolExecutor`), forked
    where that is safe (:func:`start_method`), spawned elsewhere.  The workers exit by
    themselves when the sweep's process dies, even by SIGKILL.
``ray``
    One Ray task per chunk, on a local Ray with ``workers`` CPUs, or on the existing cluster
    at ``address`` (whose nodes need acc_fusion installed).  An unreachable address is one
    error sentence within seconds (:func:`check_address`), never a hang.

SUMO chunks run one per worker process, and that process runs nothing else (libsumo allows
one simulation per process): ``max_tasks_per_child=1`` locally (Python >= 3.11), ``max_calls=1``
on Ray.
"""

from __future__ import annotations

import importlib.util
import multiprocessing
import os
import socket
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import TypeVar

import numba

from acc_fusion.core.errors import AccFusionError, ConfigError
from acc_fusion.core.pools import died, stop, watch_parent
from acc_fusion.core.validation import check_choice
from acc_fusion.sweep import EXECUTORS
from acc_fusion.sweep.chunks import run_chunk
from acc_fusion.sweep.points import Chunk

#: Seconds allowed for a TCP connection to a Ray cluster's address.
RAY_CONNECT_TIMEOUT = 5.0
#: Seconds allowed for ``ray.init`` to connect to a cluster (in a probe process).
RAY_PROBE_TIMEOUT = 30.0


T, R = TypeVar("T"), TypeVar("R")

#: An executor runs chunks and yields ``(chunk, columns)`` as they finish, in any order.
Executor = Callable[[list["Chunk"]], Iterator[tuple["Chunk", dict]]]


def _watch_parent(parent: int) -> None:
    """Worker initializer: exit when the sweep process is gone (even after SIGKILL,
    :func:`~acc_fusion.core.pools.watch_parent`); one numba thread (the pool's processes
    already share the cores)."""
    numba.set_num_threads(1)
    watch_parent(parent)


def run_alone(fn: Callable[[T], R], item: T) -> R:
    """``fn(item)`` in a worker given one core (a Ray task of ``num_cpus=1``): on one numba
    thread, as the local pool's workers."""
    numba.set_num_threads(1)
    return fn(item)


def start_method() -> str:
    """How the workers of a pool that runs many items start: ``"fork"`` on Linux (Python >=
    3.11) from a process that is safe to fork, ``"spawn"`` anywhere else.

    A forked worker begins with this process's imports and the compiled kernels it has
    loaded; a spawned one first spends about 1.6 s (on the project's 2-core VM) importing
    numba, scipy and acc_fusion and loading numba's cache, as long as a 2 000-run scripted
    chunk takes.  A process is safe to fork when no other Python thread runs (another thread
    may hold a lock the child needs: the Python docs, multiprocessing, "Contexts and start
    methods") and numba's thread pool, if a parallel kernel has started one, is not OpenMP's,
    which a forked child of GNU OpenMP cannot use (numba's docs, "The Threading Layers");
    numba's ``workqueue`` and ``tbb`` layers, OpenBLAS's and Arrow's thread pools prepare for
    a fork themselves (Python 3.12 and later still warn, with a ``DeprecationWarning``, that
    they see other OS threads).  Before 3.11 a fork pool could fork workers after its manager
    thread had started (CPython gh-90622); macOS's system libraries do not support forking.
    A pool that runs SUMO is always spawned: libsumo allows one simulation per process, and
    a fresh interpreter per run is the only way to be sure of it.
    """
    try:
        layer = numba.threading_layer()
    except ValueError:  # no parallel kernel has run here: numba has no threads
        layer = ""
    safe = threading.active_count() == 1 and layer != "omp"
    forks = sys.platform == "linux" and sys.version_info >= (3, 11)
    return "fork" if forks and safe else "spawn"


def _is_sumo(chunk: Chunk) -> bool:
    """Whether a chunk runs SUMO (and so needs a process of its own)."""
    return chunk.point.source == "sumo"


def local_map(
    fn: Callable[[T], R],
    items: list[T],
    workers: int = 2,
    fresh: Callable[[T], bool] = bool,
    label: Callable[[T], str] = str,
) -> Iterator[tuple[T, R]]:
    """``fn`` over ``items`` in a pool of ``workers`` processes, yielding ``(item, result)`` as
    each finishes; the items for which ``fresh`` is true get a spawned process each (libsumo:
    one simulation per process), the others share a pool started as :func:`start_method`
    says.  A worker's error is re-raised as it is, and one that died without raising is one
    sentence naming ``label(item)`` (:func:`~acc_fusion.core.pools.died`); after an error, or
    when the consumer stops early, the pools are stopped at once
    (:func:`~acc_fusion.core.pools.stop`)."""
    if not items:
        return
    kw = {"initializer": _watch_parent, "initargs": (os.getpid(),)}
    alone = [c for c in items if fresh(c)]
    shared = [c for c in items if not fresh(c)]
    if alone and sys.version_info < (3, 11):
        raise AccFusionError("SUMO runs in parallel need Python >= 3.11 (one process per run)")
    pools = []
    try:
        futures = {}
        if shared:
            ctx = multiprocessing.get_context(start_method())
            pools.append(ProcessPoolExecutor(workers, mp_context=ctx, **kw))
            futures |= {pools[-1].submit(fn, c): c for c in shared}
        if alone:
            ctx = multiprocessing.get_context("spawn")
            pools.append(ProcessPoolExecutor(workers, mp_context=ctx, max_tasks_per_child=1, **kw))
            futures |= {pools[-1].submit(fn, c): c for c in alone}
        while futures:
            done, _ = wait(futures, return_when=FIRST_COMPLETED)
            for f in done:
                item = futures.pop(f)
                try:
                    result = f.result()
                except BrokenProcessPool:
                    raise died(label(item)) from None
                yield item, result
    except BaseException:  # an error, or the consumer stopped early: stop at once
        for pool in pools:
            stop(pool)
        raise
    for pool in pools:
        pool.shutdown(wait=True)


def check_address(address: str, timeout: float = RAY_CONNECT_TIMEOUT) -> None:
    """Fail fast, with one sentence, when no Ray cluster answers at ``address``.

    ``address`` is ``HOST:PORT`` or ``ray://HOST:PORT`` (``"auto"``: the cluster this machine
    belongs to).  First a TCP connection within ``timeout`` [s] (refused connections, unknown
    hosts and silent networks fail here at once), then ``ray.init(address)`` in a child
    process, killed after :data:`RAY_PROBE_TIMEOUT` s: ``ray.init`` itself can wait forever on a
    server that answers but is not Ray, and a child process can be stopped where a thread
    cannot.
    """
    if address != "auto":
        hostport = address.split("://", 1)[-1].rstrip("/")
        host, _, port = hostport.rpartition(":")
        if not host or not port.isdigit():
            raise ConfigError(f"--address must be HOST:PORT or ray://HOST:PORT, got {address!r}")
        try:
            with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout):
                pass
        except OSError as exc:
            reason = exc.strerror or type(exc).__name__
            raise AccFusionError(
                f"cannot reach the Ray cluster at {address!r} within {timeout:g} s ({reason}); "
                "check the address, or leave out --address to start a local Ray"
            ) from None
    probe = "import sys, ray; ray.init(address=sys.argv[1], log_to_driver=False); ray.shutdown()"
    try:
        done = subprocess.run(
            [sys.executable, "-c", probe, address],
            capture_output=True,
            text=True,
            timeout=RAY_PROBE_TIMEOUT,
        )
    except subprocess.TimeoutExpired:
        reason = f"no answer within {RAY_PROBE_TIMEOUT:g} s"
    else:
        if done.returncode == 0:
            return
        lines = [ln for ln in done.stderr.strip().splitlines() if ln.strip()]
        reason = lines[-1].strip() if lines else f"exit code {done.returncode}"
    raise AccFusionError(
        f"cannot connect to the Ray cluster at {address!r} ({reason}); check that a Ray head "
        "node runs there, or leave out --address to start a local Ray"
    )


def ray_map(
    fn: Callable[[T], R],
    items: list[T],
    workers: int = 2,
    address: str | None = None,
    fresh: Callable[[T], bool] = bool,
) -> Iterator[tuple[T, R]]:
    """``fn`` over ``items`` as Ray tasks, yielding ``(item, result)`` as each finishes: on a
    local Ray with ``workers`` CPUs by default, or on the existing cluster at ``address`` (its
    nodes need acc_fusion installed; checked by :func:`make_map`).  An item for which ``fresh``
    is true runs in a Ray worker process that exits after it (``max_calls=1``)."""
    import ray

    if not items:
        return
    started = not ray.is_initialized()
    if started:
        kw = {"address": address} if address else {"num_cpus": workers}
        try:
            ray.init(include_dashboard=False, log_to_driver=False, **kw)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            reason = str(exc).strip().splitlines()[0] if str(exc).strip() else repr(exc)
            raise AccFusionError(f"cannot start Ray ({reason})") from None
    try:
        task = ray.remote(num_cpus=1)(run_alone)
        alone = ray.remote(num_cpus=1, max_calls=1)(run_alone)
        refs = {(alone if fresh(c) else task).remote(fn, c): c for c in items}
        while refs:
            done, _ = ray.wait(list(refs), num_returns=1)
            for ref in done:
                yield refs.pop(ref), ray.get(ref)
    finally:
        if started:
            ray.shutdown()


#: A map over items in worker processes: ``(fn, items, fresh, label)`` to ``(item, result)``
#: pairs as they finish (:func:`local_map`, :func:`ray_map`).
Mapper = Callable[..., Iterator[tuple]]


def make_map(name: str = "local", workers: int = 2, address: str | None = None) -> Mapper:
    """The map of the executor ``name`` (one of :data:`EXECUTORS`) with ``workers`` processes
    or, for Ray, the cluster at ``address``; checked at once (Ray installed, the cluster
    reachable), so that a bad setting is one sentence before any work."""
    check_choice("executor", name, EXECUTORS)
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ConfigError(f"workers must be a whole number >= 1, got {workers!r}")
    if name == "local":
        if address:
            raise ConfigError("--address needs --executor ray")
        return lambda fn, items, fresh=bool, label=str: local_map(fn, items, workers, fresh, label)
    if importlib.util.find_spec("ray") is None:
        raise ConfigError("the ray executor needs Ray: pip install 'acc_fusion[ray]'")
    if address:
        check_address(address)
    return lambda fn, items, fresh=bool, label=str: ray_map(fn, items, workers, address, fresh)


def make_executor(name: str = "local", workers: int = 2, address: str | None = None) -> Executor:
    """The executor ``name`` (one of :data:`EXECUTORS`): the chunks mapped by
    :func:`make_map`, each SUMO chunk in a process of its own."""
    mapper = make_map(name, workers, address)
    return lambda chunks: mapper(run_chunk, chunks, _is_sumo, lambda c: f"sweep chunk {c.id}")
