"""Executors of a sweep: where its chunks run (:mod:`acc_fusion.sweep.run`).

An executor takes the chunks still to run and yields ``(chunk, columns)`` as each finishes,
in any order; the sweep stores every chunk's rows as it arrives.  A chunk's rows depend only
on the chunk (:func:`acc_fusion.sweep.chunks.run_chunk`), so every executor gives the same rows.

``local`` (default)
    A pool of ``workers`` spawned processes (:class:`concurrent.futures.ProcessPoolExecutor`).
    The workers exit by themselves when the sweep's process dies, even by SIGKILL.
``ray``
    One Ray task per chunk, on a local Ray with ``workers`` CPUs, or on the existing cluster
    at ``address`` (whose nodes need acc_fusion installed).  An unreachable address is one
    error sentence within seconds (:func:`check_address`), never a hang.

SUMO chunks run one per worker process, and that process runs nothing else (libsumo allows
one simulation per process): ``max_tasks_per_child=1`` locally (Python >= 3.11), ``max_calls=1``
on Ray.
"""

from __future__ import annotations

import multiprocessing
import os
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

import numba

from acc_fusion.core.errors import AccFusionError, ConfigError
from acc_fusion.core.pools import died, stop
from acc_fusion.core.validation import check_choice
from acc_fusion.sweep import EXECUTORS
from acc_fusion.sweep.chunks import run_chunk
from acc_fusion.sweep.points import Chunk

#: Seconds allowed for a TCP connection to a Ray cluster's address.
RAY_CONNECT_TIMEOUT = 5.0
#: Seconds allowed for ``ray.init`` to connect to a cluster (in a probe process).
RAY_PROBE_TIMEOUT = 30.0


#: An executor runs chunks and yields ``(chunk, columns)`` as they finish, in any order.
Executor = Callable[[list["Chunk"]], Iterator[tuple["Chunk", dict]]]


def _watch_parent(parent: int) -> None:
    """Worker initializer: exit when the sweep process is gone (even after SIGKILL); one
    numba thread (the pool's processes already share the cores)."""
    numba.set_num_threads(1)

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def run_chunk_alone(chunk: Chunk) -> dict:
    """:func:`~acc_fusion.sweep.chunks.run_chunk` in a worker given one core (a Ray task of
    ``num_cpus=1``): on one numba thread, as the local pool's workers."""
    numba.set_num_threads(1)
    return run_chunk(chunk)


def local_executor(workers: int = 2) -> Executor:
    """A pool of ``workers`` processes (spawned); SUMO chunks get a fresh process each."""

    def run(chunks: list[Chunk]) -> Iterator[tuple[Chunk, dict]]:

        if not chunks:
            return
        ctx = multiprocessing.get_context("spawn")
        kw = {"mp_context": ctx, "initializer": _watch_parent, "initargs": (os.getpid(),)}
        sumo = [c for c in chunks if c.point.source == "sumo"]
        scripted = [c for c in chunks if c.point.source != "sumo"]
        if sumo and sys.version_info < (3, 11):
            raise AccFusionError("SUMO sweeps need Python >= 3.11 (one process per SUMO run)")
        pools = []
        try:
            futures = {}
            if scripted:
                pools.append(ProcessPoolExecutor(workers, **kw))
                futures |= {pools[-1].submit(run_chunk, c): c for c in scripted}
            if sumo:
                pools.append(ProcessPoolExecutor(workers, max_tasks_per_child=1, **kw))
                futures |= {pools[-1].submit(run_chunk, c): c for c in sumo}
            while futures:
                done, _ = wait(futures, return_when=FIRST_COMPLETED)
                for f in done:
                    chunk = futures.pop(f)
                    try:
                        columns = f.result()
                    except BrokenProcessPool:
                        raise died(f"sweep chunk {chunk.id}") from None
                    yield chunk, columns
        except BaseException:  # an error, or the consumer stopped early: stop at once
            for pool in pools:
                stop(pool)
            raise
        for pool in pools:
            pool.shutdown(wait=True)

    return run


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


def ray_executor(workers: int = 2, address: str | None = None) -> Executor:
    """Ray tasks, one per chunk: a local Ray with ``workers`` CPUs by default, or the existing
    cluster at ``address`` (its nodes need acc_fusion installed).  A SUMO chunk runs in a Ray
    worker process that exits after it (``max_calls=1``)."""
    try:
        import ray
    except ImportError:
        raise ConfigError("the ray executor needs Ray: pip install 'acc_fusion[ray]'") from None
    if address:
        check_address(address)

    def run(chunks: list[Chunk]) -> Iterator[tuple[Chunk, dict]]:
        if not chunks:
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
            task = ray.remote(num_cpus=1)(run_chunk_alone)
            sumo_task = ray.remote(num_cpus=1, max_calls=1)(run_chunk_alone)
            refs = {(sumo_task if c.point.source == "sumo" else task).remote(c): c for c in chunks}
            while refs:
                done, _ = ray.wait(list(refs), num_returns=1)
                for ref in done:
                    yield refs.pop(ref), ray.get(ref)
        finally:
            if started:
                ray.shutdown()

    return run


def make_executor(name: str = "local", workers: int = 2, address: str | None = None) -> Executor:
    """The executor ``name`` (one of :data:`EXECUTORS`)."""
    check_choice("executor", name, EXECUTORS)
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ConfigError(f"workers must be a whole number >= 1, got {workers!r}")
    if name == "local":
        if address:
            raise ConfigError("--address needs --executor ray")
        return local_executor(workers)
    return ray_executor(workers, address)
