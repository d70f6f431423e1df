"""Blobs in the jobs' database (``BLOB_STORE=postgres``, the scaled default): one row of the ``blobs``
table per key, so that the API and workers on different machines share them with no service beyond
PostgreSQL. A download reads the value in slices (``substr``), so it streams without holding the whole
blob in the API's memory. Works on SQLite too (tests), though there a local directory is the default.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

from sqlalchemy import LargeBinary, delete, func, select
from sqlalchemy import exc as sqlalchemy_exc

from plantsolve.store.blobs import BlobMissing, BlobReader, BlobStore, BlobStoreUnavailable, StoredBlob, check_key, digest
from plantsolve.store.engine import Database
from plantsolve.store.models import Blob, utcnow

READ_SLICE_BYTES = 4 * 1024 * 1024  # one query per 4 MiB slice: few round trips, bounded memory

# the database is away (not a statement the code got wrong): the caller may try again
_AWAY = (sqlalchemy_exc.OperationalError, sqlalchemy_exc.InterfaceError, sqlalchemy_exc.DisconnectionError,
         sqlalchemy_exc.TimeoutError)


class DatabaseBlobStore(BlobStore):
    kind = "postgres"

    def __init__(self, db: Database):
        self.db = db

    def put(self, key: str, data: bytes) -> StoredBlob:
        stored = StoredBlob(check_key(key), len(data), digest(data))
        with _reachable(), self.db.writing(), self.db.engine.begin() as connection:
            connection.execute(delete(Blob).where(Blob.key == key))  # a put replaces, in one transaction
            connection.execute(Blob.__table__.insert().values(key=key, size=stored.size, sha256=stored.sha256,
                                                              data=bytes(data), created_at=utcnow()))
        return stored

    def open(self, key: str) -> BlobReader:
        with _reachable(), self.db.engine.connect() as connection:
            size = connection.execute(select(Blob.size).where(Blob.key == check_key(key))).scalar_one_or_none()
        if size is None:
            raise BlobMissing(key)
        return BlobReader(size, self._slices(key, size))

    def exists(self, key: str) -> bool:
        with _reachable(), self.db.engine.connect() as connection:
            return connection.execute(select(Blob.key).where(Blob.key == check_key(key))).first() is not None

    def delete(self, key: str) -> None:
        with _reachable(), self.db.writing(), self.db.engine.begin() as connection:
            connection.execute(delete(Blob).where(Blob.key == check_key(key)))

    def keys(self, prefix: str) -> Iterator[str]:
        """A scan of the keys (no index serves a prefix under every collation): for sweeps, not per job."""
        with _reachable(), self.db.engine.connect() as connection:
            found = connection.execute(select(Blob.key).where(Blob.key.startswith(prefix, autoescape=True))).scalars()
            return iter(list(found))

    def _slices(self, key: str, size: int) -> Iterator[bytes]:
        for offset in range(0, size, READ_SLICE_BYTES):
            with _reachable(), self.db.engine.connect() as connection:
                piece = connection.execute(
                    select(func.substr(Blob.data, offset + 1, READ_SLICE_BYTES, type_=LargeBinary)).where(Blob.key == key)
                ).scalar_one_or_none()
            if piece is None:  # deleted while it was read
                raise BlobMissing(key)
            yield bytes(piece)


@contextmanager
def _reachable() -> Iterator[None]:
    """Turns 'the database is away' into :class:`BlobStoreUnavailable`."""
    try:
        yield
    except sqlalchemy_exc.SQLAlchemyError as error:
        if isinstance(error, _AWAY) or getattr(error, "connection_invalidated", False):
            raise BlobStoreUnavailable(f"the database holding the blobs is unreachable: {type(error).__name__}") from error
        raise
