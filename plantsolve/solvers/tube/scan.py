"""The tube kind's input value: a request with its samples decoded once (checks, solve and artifacts share them)."""

from __future__ import annotations

import base64
import binascii
import io
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from plantsolve.schemas.tube import MAX_POINTS, NpyPoints, TubeRequest
from plantsolve.solvers.base import StoredInput


@dataclass(frozen=True)
class TubeScan:
    """One scan of a bent tube: the ``request`` and, on first use, its samples as ``points``.

    Decoding is lazy so that building a scan never fails: a bad NPY payload is reported by the
    input check (naming ``points``), not by whoever made the scan. A scan reads its request's
    points once; for changed points, make a new scan."""

    request: TubeRequest

    @classmethod
    def load(cls, request: TubeRequest, source: StoredInput | None = None) -> "TubeScan":
        """The spec's ``load``: an upload's samples are already in the request (``parse_upload`` put them there)."""
        return cls(request)

    @cached_property
    def points(self) -> np.ndarray:
        """The samples as an (N, 3) float64 array, read-only so that no stage edits another's input.
        A bad NPY payload raises ValueError with the reason."""
        points = self.request.points
        if isinstance(points, NpyPoints):
            array = decode_npy_points(points.npy_base64)
        else:
            array = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        array.setflags(write=False)
        return array


def decode_npy_points(value: str) -> np.ndarray:
    """Decode a base64 NPY string into an (N, 3) float64 array; ValueError with a reason."""
    try:
        raw = base64.b64decode(value, validate=False)
    except (binascii.Error, ValueError) as exc:
        raise ValueError(f"not valid base64: {exc}") from None
    try:
        arr = np.load(io.BytesIO(raw), allow_pickle=False)
    except Exception as exc:  # numpy raises several types for corrupt headers
        raise ValueError(f"not a readable NPY array: {exc}") from None
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"NPY array must have shape (N, 3), got {arr.shape}")
    if not np.issubdtype(arr.dtype, np.number):
        raise ValueError(f"NPY array must be numeric, got dtype {arr.dtype}")
    if arr.shape[0] > MAX_POINTS:
        raise ValueError(f"at most {MAX_POINTS} points are accepted, got {arr.shape[0]}")
    arr = np.asarray(arr, dtype=np.float64)
    if not np.isfinite(arr).all():
        bad = int(np.flatnonzero(~np.isfinite(arr).all(axis=1))[0])
        raise ValueError(f"NPY array holds non-finite values (first at row {bad})")
    return arr
