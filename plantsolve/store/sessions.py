"""Every read and write of the dashboard's login sessions and failed logins (the app decides their policy:
lifetimes, limits, what a token is)."""

from __future__ import annotations

from contextlib import AbstractContextManager, nullcontext
from datetime import datetime
from typing import Callable

from sqlalchemy import delete, func, select
from sqlalchemy.orm import Session, sessionmaker

from plantsolve.store.models import DashboardSession, LoginFailure
from plantsolve.store.repository import as_utc


class SessionRepository:
    def __init__(self, sessions: sessionmaker[Session], writing: Callable[[], AbstractContextManager] = nullcontext):
        self.sessions = sessions
        self.writing = writing  # see Database.writing

    def open(self, token_hash: str, key_hash: str, now: datetime, expires_at: datetime) -> None:
        """Store a new session; sessions that have expired are deleted on the way (no sweeper needed)."""
        with self.writing(), self.sessions() as session:
            session.execute(delete(DashboardSession).where(DashboardSession.expires_at <= now))
            session.add(DashboardSession(token_hash=token_hash, key_hash=key_hash, created_at=now,
                                         expires_at=expires_at))
            session.commit()

    def key_of(self, token_hash: str, now: datetime) -> str | None:
        """The key hash of a session that is open and has not expired, else None."""
        with self.sessions() as session:
            return session.scalar(select(DashboardSession.key_hash).where(
                DashboardSession.token_hash == token_hash, DashboardSession.expires_at > now))

    def close(self, token_hash: str) -> bool:
        with self.writing(), self.sessions() as session:
            count = session.execute(delete(DashboardSession).where(DashboardSession.token_hash == token_hash)).rowcount
            session.commit()
            return count == 1

    def record_failure(self, address: str, now: datetime, forget_before: datetime) -> None:
        """Count one failed login of ``address``; failures older than ``forget_before`` are deleted."""
        with self.writing(), self.sessions() as session:
            session.execute(delete(LoginFailure).where(LoginFailure.at < forget_before))
            session.add(LoginFailure(address=address, at=now))
            session.commit()

    def failures_since(self, address: str, since: datetime) -> tuple[int, datetime | None]:
        """How many logins of ``address`` failed after ``since``, and when the oldest of them did."""
        with self.sessions() as session:
            count, oldest = session.execute(select(func.count(), func.min(LoginFailure.at)).where(
                LoginFailure.address == address, LoginFailure.at > since)).one()
            return int(count), as_utc(oldest)
