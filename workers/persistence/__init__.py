"""The database (source of truth for jobs) and the artifact file store.

Lives under ``workers`` because both the API and the workers use it and ``app`` is
imported by nobody (design.md).
"""

from workers.persistence.engine import Database
from workers.persistence.files import FileStore
from workers.persistence.repository import JobRepository

__all__ = ["Database", "FileStore", "JobRepository"]
