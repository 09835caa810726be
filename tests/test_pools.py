"""Process pools (:mod:`acc_fusion.core.pools`, :func:`acc_fusion.sweep.executors.local_map`):
a worker does not outlive the process that made its pool, even when that process is killed,
whether the worker was spawned or forked."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

CHILD = """
import os, sys, time
from acc_fusion.core.pools import process_pool

if __name__ == "__main__":
    with process_pool("a long job", 1) as pool:
        pid = pool.submit(os.getpid).result()
        print(pid, flush=True)
        pool.submit(time.sleep, 600).result()
"""

#: The same with a sweep's pool, whose workers are forked from a process with one thread.
FORKED = """
import os, time
from acc_fusion.sweep.executors import local_map, start_method

def pid_or_sleep(i):
    return os.getpid() if i == 0 else time.sleep(600)

if __name__ == "__main__":
    assert start_method() == "fork"
    for _, pid in local_map(pid_or_sleep, [0, 1], workers=1):
        print(pid, flush=True)
"""


@pytest.mark.parametrize(
    "sig, child",
    [(signal.SIGTERM, CHILD), (signal.SIGKILL, CHILD)]
    + ([(signal.SIGKILL, FORKED)] if sys.platform == "linux" else []),
)
def test_a_pools_workers_exit_when_its_process_is_killed(tmp_path: Path, sig, child):
    script = tmp_path / "child.py"
    script.write_text(child)
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    worker = int(proc.stdout.readline())
    os.kill(proc.pid, sig)
    proc.wait()
    deadline = time.monotonic() + 60.0  # the worker checks every 0.5 s; a loaded machine
    while time.monotonic() < deadline:
        try:
            os.kill(worker, 0)
        except ProcessLookupError:
            return
        time.sleep(0.2)
    os.kill(worker, signal.SIGKILL)
    pytest.fail(f"worker {worker} still ran 60 s after its pool's process was killed")
