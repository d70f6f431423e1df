"""A job process keeps the memory it frees for its next array instead of mapping fresh pages each time."""

import subprocess
import sys

PROBE = """
import ctypes, numpy as np, sys
from plantsolve.workers import processes

class MallInfo2(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in
                ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks",
                 "keepcost")]

libc = ctypes.CDLL("libc.so.6")
libc.mallinfo2.restype = MallInfo2
if sys.argv[1] == "job":
    processes._keep_freed_memory()
before = libc.mallinfo2().hblks
big = np.ones(100_000_000 // 8)  # 100 MB: above glibc's default mmap threshold
mapped = libc.mallinfo2().hblks - before
del big
print(mapped, libc.mallinfo2().fordblks >= 100_000_000)
"""


def _probe(role: str) -> str:
    return subprocess.run([sys.executable, "-c", PROBE, role], capture_output=True, text=True, check=True).stdout.split()


def test_a_job_process_takes_a_large_array_from_its_heap_and_keeps_it_when_freed():
    assert _probe("job") == ["0", "True"]


def test_without_it_the_array_is_mapped_and_given_back():
    assert _probe("default") == ["1", "False"]
