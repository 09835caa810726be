"""Process pools (:mod:`acc_fusion.core.pools`): a worker does not outlive the process that
made its pool, even when that process is killed."""

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


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_a_pools_workers_exit_when_its_process_is_killed(tmp_path: Path, sig):
    script = tmp_path / "child.py"
    script.write_text(CHILD)
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
