"""Free space on the disks the store writes to: the folder of the local blob store and spool (``ARTIFACT_DIR``) and
the SQLite file's folder. Below ``MIN_FREE_DISK_BYTES`` the service is not ready (``/readyz`` 503 naming ``disk``):
a job taken now could be solved and then find no room for its result, or a submission no room for its upload."""

from __future__ import annotations

import os
import shutil
from pathlib import Path


class DiskLow(OSError):
    """A folder's disk has less free space than the floor."""


def free_bytes(folder: Path) -> int:
    """Free space, in bytes, for an unprivileged writer on the disk that holds ``folder`` (or would: a folder not
    made yet is counted on its nearest existing parent's disk)."""
    return shutil.disk_usage(_existing(folder)).free


def check_free_space(folders: dict[str, Path], floor: int) -> None:
    """Raise :class:`DiskLow` naming each disk (one folder of it, by its role) with less than ``floor`` bytes free;
    a floor of 0 checks nothing."""
    if floor <= 0:
        return
    low, seen = [], set()
    for role, folder in folders.items():
        free = free_bytes(folder)
        device = os.stat(_existing(folder)).st_dev
        if free < floor and device not in seen:
            seen.add(device)
            low.append(f"{role} ({folder}): {free / 2**20:.0f} MiB free")
    if low:
        raise DiskLow(f"less than MIN_FREE_DISK_BYTES ({floor / 2**20:.0f} MiB) free: " + "; ".join(low))


def _existing(folder: Path) -> Path:
    path = Path(folder).absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    return path
