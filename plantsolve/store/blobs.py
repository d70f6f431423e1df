"""Blobs: the bytes of uploads, large JSON requests, artifacts and spooled results, by key.

A key is ``<job id>/<name>`` or ``<job id>/a<attempt>/<name>``; the database keeps each artifact's
name, media type, size and SHA-256, the blob store its bytes. Three back-ends share one interface,
so that no process needs a disk another one writes:

- :class:`LocalBlobStore` — files under ``ARTIFACT_DIR`` (the embedded default; one machine, or a
  shared volume);
- :class:`~plantsolve.store.blobs_database.DatabaseBlobStore` — a ``blobs`` table in the jobs'
  database (the scaled default on PostgreSQL: no extra service);
- :class:`~plantsolve.store.blobs_s3.S3BlobStore` — an S3-compatible bucket (boto3).

Two errors cross the interface: :class:`BlobMissing` (no such key: the API answers 404) and
:class:`BlobStoreUnavailable` (the back-end cannot be reached: a ``ConnectionError``, so the API
answers 503 and the runner retries). :meth:`BlobStore.open` fetches the size (and, where it costs
nothing, the first bytes) eagerly, so both errors are raised before an HTTP response has started.
"""

from __future__ import annotations

import hashlib
import os
import re
import tempfile
from abc import ABC, abstractmethod
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

CHUNK_BYTES = 1024 * 1024  # what a download streams at a time: 1 MiB

_KEY = re.compile(r"^[^/\\\x00-\x1f]+(/[^/\\\x00-\x1f]+)*$")  # names without separators or control characters


class BlobMissing(LookupError):
    """No blob under this key."""

    def __init__(self, key: str):
        self.key = key
        super().__init__(f"no blob {key!r}")


class BlobStoreUnavailable(ConnectionError):
    """The back-end could not be reached (network, disk, database): another try may succeed."""


@dataclass(frozen=True)
class StoredBlob:
    """What a put stored: the key, its size in bytes and the SHA-256 (hex) of its bytes."""

    key: str
    size: int
    sha256: str


class BlobReader:
    """An opened blob: its ``size`` in bytes and its bytes in chunks (read once), then :meth:`close`."""

    def __init__(self, size: int, chunks: Iterator[bytes], close: Callable[[], None] = lambda: None):
        self.size = size
        self._chunks = chunks
        self._close = close

    def chunks(self) -> Iterator[bytes]:
        try:
            yield from self._chunks
        finally:
            self.close()

    def read(self) -> bytes:
        return b"".join(self.chunks())

    def close(self) -> None:
        close, self._close = self._close, lambda: None
        close()


def check_key(key: str) -> str:
    """A key is relative: names separated by '/', none of them '.' or '..'."""
    if not _KEY.match(key) or any(part in (".", "..") for part in key.split("/")) or len(key) > 512:
        raise ValueError(f"not a blob key: {key!r}")
    return key


class BlobStore(ABC):
    """Bytes by key. Puts are whole (a reader never sees half a blob) and replace what was there."""

    kind: str  # "local" | "postgres" | "s3": what BLOB_STORE names

    @abstractmethod
    def put(self, key: str, data: bytes) -> StoredBlob: ...

    @abstractmethod
    def open(self, key: str) -> BlobReader:
        """The blob, opened: raises :class:`BlobMissing` or :class:`BlobStoreUnavailable` here, not later."""

    @abstractmethod
    def exists(self, key: str) -> bool: ...

    @abstractmethod
    def delete(self, key: str) -> None:
        """Remove the blob; a missing one is no error."""

    @abstractmethod
    def keys(self, prefix: str) -> Iterator[str]:
        """The keys that start with ``prefix`` (a folder's, ending in '/'), in no set order. A listing, for sweeps
        of a few blobs kept under one prefix (the spool), not for a job's reads."""

    def get(self, key: str) -> bytes:
        return self.open(key).read()

    @contextmanager
    def local_file(self, key: str, name: str = "") -> Iterator[Path]:
        """A path on this machine holding the blob's bytes, for readers that open files (IfcOpenShell):
        a temporary copy, removed when the block ends (the local back-end yields its own file)."""
        reader = self.open(key)
        with tempfile.TemporaryDirectory(prefix="plantsolve-blob-") as folder:
            path = Path(folder) / (re.sub(r"[^A-Za-z0-9._-]+", "_", name or key.rsplit("/", 1)[-1])[-120:] or "blob")
            with path.open("wb") as handle:
                for chunk in reader.chunks():
                    handle.write(chunk)
            yield path


def temporary_prefix(pid: int) -> str:
    """How the temporary files of a put by process ``pid`` begin (the pid: a killed writer's are found by it)."""
    return f".tmp-{pid}-"


def digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


class LocalBlobStore(BlobStore):
    """Files under ``root`` (``ARTIFACT_DIR``). Writes go to a temporary name and are renamed into
    place, so a reader never sees half a file and a crashed writer leaves no partial blob."""

    kind = "local"

    def __init__(self, root: Path):
        self.root = Path(root)

    def put(self, key: str, data: bytes) -> StoredBlob:
        """Write the blob; on any failure (a full disk mid-write, at the close or at the rename) nothing of it is
        left: neither its temporary file nor a folder left empty (:meth:`_prune`)."""
        target = self.path(key)
        tmp = None
        try:
            fd, tmp = self._temporary(target.parent)
            with os.fdopen(fd, "wb") as handle:
                handle.write(data)
            os.replace(tmp, target)
        except BaseException:
            if tmp is not None:
                Path(tmp).unlink(missing_ok=True)
            self._prune(target.parent)
            raise
        return StoredBlob(key, len(data), digest(data))

    def open(self, key: str) -> BlobReader:
        try:
            handle = self.path(key).open("rb")
        except (FileNotFoundError, NotADirectoryError, IsADirectoryError):
            raise BlobMissing(key) from None
        except OSError as error:
            raise BlobStoreUnavailable(f"the blob folder cannot be read: {error.strerror}") from error
        size = os.fstat(handle.fileno()).st_size
        return BlobReader(size, iter(lambda: handle.read(CHUNK_BYTES), b""), handle.close)

    def exists(self, key: str) -> bool:
        return self.path(key).is_file()

    def delete(self, key: str) -> None:
        """Remove the blob and the folders it leaves empty (a refused upload's ``<job id>/input``: each would
        otherwise stay behind, one per refusal)."""
        path = self.path(key)
        path.unlink(missing_ok=True)
        self._prune(path.parent)

    def keys(self, prefix: str) -> Iterator[str]:
        """Every file under the prefix's folder, a temporary one that a killed put left behind too (its name starts
        with '.tmp-'; deleting it by its key removes it)."""
        folder = self.path(check_key(prefix.rstrip("/")))
        root = self.root.resolve()
        try:
            found = [path.relative_to(root).as_posix() for path in folder.rglob("*") if path.is_file()]
        except OSError as error:
            raise BlobStoreUnavailable(f"the blob folder cannot be read: {error.strerror}") from error
        return iter(found)

    def _temporary(self, folder: Path) -> tuple[int, str]:
        """A new temporary file in ``folder``, made if missing."""
        try:
            try:
                folder.mkdir(parents=True, exist_ok=True)
                return tempfile.mkstemp(dir=folder, prefix=temporary_prefix(os.getpid()))
            except FileNotFoundError:  # a prune removed the folder between its making and the file's
                folder.mkdir(parents=True, exist_ok=True)
                return tempfile.mkstemp(dir=folder, prefix=temporary_prefix(os.getpid()))
        except OSError as error:
            raise BlobStoreUnavailable(f"the blob folder cannot be written: {error.strerror}") from error

    def remove_temporaries(self, prefix: str, pid: int) -> int:
        """Remove the temporary files that process ``pid`` left under the prefix's folder: a process killed in the
        middle of a put (its temporary file is never renamed into place, nor removed). Returns how many went."""
        removed = 0
        for key in self.keys(prefix):
            path = self.path(key)
            if path.name.startswith(temporary_prefix(pid)):
                path.unlink(missing_ok=True)
                self._prune(path.parent)
                removed += 1
        return removed

    def _prune(self, folder: Path) -> None:
        """Remove ``folder`` and its parents below the root while they are empty."""
        root = self.root.resolve()
        while folder != root and folder.is_relative_to(root):
            try:
                folder.rmdir()
            except OSError:  # not empty (another blob, or a write under way), or gone already
                return
            folder = folder.parent

    @contextmanager
    def local_file(self, key: str, name: str = "") -> Iterator[Path]:
        path = self.path(key)
        if not path.is_file():
            raise BlobMissing(key)
        yield path

    def path(self, key: str) -> Path:
        """Where the blob's file lies (or would)."""
        target = (self.root / check_key(key)).resolve()
        if not target.is_relative_to(self.root.resolve()):
            raise ValueError(f"path escapes the store: {key!r}")
        return target
