"""Reading processes forked from the reading process itself (``start="fork"``, the CLI's): the same bounds as
the service's forkserver children, and refused from a process with more than one thread. Each case runs in a
fresh interpreter: a test process has threads of its own."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np

SCRIPT = textwrap.dedent("""
    import sys, threading
    from plantsolve.jobs import intake
    from plantsolve.jobs.errors import Unprocessable
    from plantsolve.solvers.kinds import load_kinds
    from plantsolve.solvers.base import StoredInput

    path, memory, threads = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    spec = load_kinds()["tube"]
    stop = threading.Event()
    for _ in range(threads - 1):
        threading.Thread(target=stop.wait, daemon=True).start()
    try:
        intake.read_upload_bounded(spec, StoredInput.from_path(path), None, memory_bytes=memory, start="fork")
        print("ok")
    except Unprocessable as error:
        print("refused", error.errors[0]["loc"], error.errors[0]["type"])
    except RuntimeError as error:
        print("error", error)
    finally:
        stop.set()
""")


def _read(path, memory: int, threads: int = 1) -> str:
    run = subprocess.run([sys.executable, "-c", SCRIPT, str(path), str(memory), str(threads)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    return run.stdout.strip()


def test_a_forked_reader_is_bounded_as_the_service_reader_is(tmp_path):
    big, small = tmp_path / "cloud.npy", tmp_path / "small.npy"
    np.save(big, np.random.default_rng(0).normal(size=(2_000_000, 3)))  # 48 MB read into arrays
    np.save(small, np.random.default_rng(0).normal(size=(2_000, 3)))
    assert _read(big, 16 * 2**20) == "refused ['file'] too_large"
    assert _read(small, 768 * 2**20) == "ok"


def test_a_process_with_threads_does_not_fork_its_readers(tmp_path):
    small = tmp_path / "small.npy"
    np.save(small, np.random.default_rng(0).normal(size=(2_000, 3)))
    assert _read(small, 768 * 2**20, threads=2).startswith("error reading processes are forked only")
