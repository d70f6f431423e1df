"""A dispatcher for tests of the job domain: it records what is enqueued and sends nothing; and the job row of an
upload stored through it."""

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


def stored_upload(ctx, kind: str, name: str, content: bytes) -> uuid.UUID:
    """The job row of an upload that the intake took (its bounded reading has its own tests), stored through the
    job service with a :class:`Recorder`."""
    from plantsolve.jobs.service import JobService, NewJob

    job_id = uuid.uuid4()
    blob = ctx.files.put(f"{job_id}/input/{name}", content)
    new = NewJob(ctx.spec(kind), job_id, uuid.uuid4().hex, None,
                 {"input_kind": "upload", "input_file": blob.key, "input_filename": name, "input_options": None})
    return JobService(ctx, Recorder()).store(new).job.id


def queued_test_job(ctx) -> uuid.UUID:
    """A job of the test kind ``test-compute`` submitted through the job service (nothing dispatched): queued."""
    from plantsolve.jobs.service import JobService

    return JobService(ctx, Recorder(), readers=[]).submit_json("test-compute", b'{"values": [1]}', None).job.id
