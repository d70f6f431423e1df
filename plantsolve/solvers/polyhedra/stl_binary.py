"""A binary STL's triangles as arrays, read by numpy alone.

The format is an 80-byte header, a little-endian uint32 triangle count, then per triangle a float32 normal,
three float32 corners and a 2-byte attribute. Read with trimesh, a million-triangle file first paid for importing
trimesh (networkx, SciPy's optimizers and more: half a second and 35 MB, in the upload's reader and again in the
job) to unpack this one record type. The arrays are those trimesh's ``load_stl`` gives: every facet's corners kept
apart, in file order.
"""

from __future__ import annotations

import numpy as np

HEADER_BYTES = 84
RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


def is_binary_stl(content: bytes) -> bool:
    """Whether the size is what the header's triangle count says (trimesh's test too: a binary file whose header
    begins with 'solid', as some CAD tools write it, is still binary)."""
    if len(content) < HEADER_BYTES:
        return False
    return HEADER_BYTES + RECORD.itemsize * int(np.frombuffer(content, "<u4", 1, 80)[0]) == len(content)


def binary_stl_arrays(content: bytes) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (3n, 3) float32, a view of ``content``; triangles (n, 3) int64: 0 1 2, 3 4 5, …) of a file for
    which :func:`is_binary_stl` holds."""
    records = np.frombuffer(content, RECORD, offset=HEADER_BYTES)
    return records["corners"].reshape(-1, 3), np.arange(3 * len(records), dtype=np.int64).reshape(-1, 3)
