"""Structured logs: one JSON object per line on stderr for the ``plantsolve`` loggers.

Fields: ``time`` (UTC, ISO 8601), ``level``, ``logger``, ``message``, and whatever a call passes in
``extra`` among :data:`FIELDS` (a finished job attempt logs ``job_id``, ``kind``, ``attempt``,
``duration_seconds``, ``outcome``, ``worker``; an HTTP request's log lines carry ``request_id``, the
``X-Request-ID`` the API answered with). ``LOG_FORMAT=text`` gives plain lines instead. The
``plantsolve`` logger then writes its lines itself and does not pass them on to the root logger.

Third-party libraries' log lines (pint, matplotlib, …, warning and above) and Python ``warnings`` are written by
the same handler, so every line of a process's log is in its format: it is put on the root logger when nothing
else (a host application, Celery) has configured that one.
"""

from __future__ import annotations

import json
import logging
from datetime import datetime, timezone

FIELDS = ("job_id", "kind", "attempt", "duration_seconds", "outcome", "worker", "status", "request_id", "error")
_MARK = "_plantsolve_handler"


class JsonFormatter(logging.Formatter):
    def format(self, record: logging.LogRecord) -> str:
        document = {
            "time": datetime.fromtimestamp(record.created, timezone.utc).isoformat(timespec="milliseconds"),
            "level": record.levelname,
            "logger": record.name,
            "message": record.getMessage(),
        }
        for name in FIELDS:
            value = getattr(record, name, None)
            if value not in (None, "", "-"):
                document[name] = value
        if record.exc_info:
            document["exception"] = self.formatException(record.exc_info)
        return json.dumps(document, default=str, ensure_ascii=False)


def configure_logging(log_format: str = "json", level: int | str = logging.INFO,
                      filters: tuple[logging.Filter, ...] = ()) -> logging.Handler:
    """Give the ``plantsolve`` loggers their handler, once per process (later calls return it), and ``level``
    (a name such as ``"warning"`` or a number): the least severe line they write."""
    logger = logging.getLogger("plantsolve")
    logger.setLevel(level.upper() if isinstance(level, str) else level)
    logging.captureWarnings(True)  # Python warnings become log records (logger py.warnings), not stderr text
    for handler in logger.handlers:
        if getattr(handler, _MARK, False):
            return handler
    handler = logging.StreamHandler()
    setattr(handler, _MARK, True)
    handler.setFormatter(JsonFormatter() if log_format == "json"
                         else logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    for log_filter in filters:
        handler.addFilter(log_filter)
    logger.addHandler(handler)
    # written once, here: a root handler set up by the command line or a host application would repeat each line
    logger.propagate = False
    root = logging.getLogger()
    if not root.handlers:  # third-party lines: ours to write only where nobody else writes them
        root.addHandler(handler)
        root.setLevel(max(logging.WARNING, logger.level))
    return handler
