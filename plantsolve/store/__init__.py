"""The store: the database that is the source of truth for jobs, and the blob store (uploads, artifacts,
spooled results) of the configured back-end.

Both the app (submissions, reads) and the workers (claims, results) use it; it imports neither
of them, nor any solver.
"""

from __future__ import annotations

import importlib

# Names re-exported from the modules that define them, imported on first use: a process that only reads the
# settings (``plantsolve solve --help``, the settings of the app) does not pay for SQLAlchemy and the blob clients.
_EXPORTS = {
    "BlobMissing": "blobs", "BlobStore": "blobs", "BlobStoreUnavailable": "blobs", "LocalBlobStore": "blobs",
    "Database": "engine", "JobRepository": "repository", "SessionRepository": "sessions",
    "StoreSettings": "settings", "Store": "handle", "open_blob_store": "handle",
}


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)


__all__ = sorted(_EXPORTS)
