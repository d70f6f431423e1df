"""Artifact and upload files on disk.

Files live under ``<ARTIFACT_DIR>/<job id>/``; the database keeps name, media type, size and
SHA-256 of each. Writes go to a temporary name and are renamed into place, so a reader never
sees half a file and a crashed writer leaves no partial artifact.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path


class FileStore:
    def __init__(self, root: Path):
        self.root = Path(root)

    def put(self, relpath: str, data: bytes) -> tuple[str, int, str]:
        """Store ``data`` at ``relpath``; returns (relpath, size, sha256 hex)."""
        target = self._resolve(relpath)
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=".tmp-")
        try:
            with os.fdopen(fd, "wb") as handle:
                handle.write(data)
            os.replace(tmp, target)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return relpath, len(data), hashlib.sha256(data).hexdigest()

    def read(self, relpath: str) -> bytes:
        return self._resolve(relpath).read_bytes()

    def path(self, relpath: str) -> Path:
        return self._resolve(relpath)

    def _resolve(self, relpath: str) -> Path:
        target = (self.root / relpath).resolve()
        if not target.is_relative_to(self.root.resolve()):
            raise ValueError(f"path escapes the store: {relpath!r}")
        return target
