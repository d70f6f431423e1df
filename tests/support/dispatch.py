"""A dispatcher for tests of the job domain: it records what is enqueued and sends nothing."""

from __future__ import annotations

import uuid


class Recorder:
    def __init__(self):
        self.enqueued: list[uuid.UUID] = []

    def enqueue(self, job_id, kind=""):
        self.enqueued.append(job_id)

    def ping(self): ...
    def start(self): ...
    def stop(self): ...
