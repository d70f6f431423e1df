"""Reading Server-Sent Events in tests: a response's lines to (event, data) pairs."""

from __future__ import annotations

import json
import time
from typing import Iterator


def events(lines: Iterator[str], *, deadline: float | None = None, comments: list[str] | None = None) -> Iterator[tuple[str, dict]]:
    """(event name, parsed JSON data) per event; comment lines go to ``comments``. Stops with an
    AssertionError once ``deadline`` (time.monotonic) has passed (pings keep the lines coming)."""
    name, data = "message", []
    for line in lines:
        if deadline is not None and time.monotonic() > deadline:
            raise AssertionError("the expected events did not arrive in time")
        if line.startswith(":"):
            if comments is not None:
                comments.append(line[1:].strip())
            continue
        if not line:
            if data:
                yield name, json.loads("\n".join(data))
            name, data = "message", []
            continue
        field, _, value = line.partition(":")
        value = value[1:] if value.startswith(" ") else value
        if field == "event":
            name = value
        elif field == "data":
            data.append(value)
