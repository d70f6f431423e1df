"""Celery's task message of a job as kombu puts it onto a Redis queue, made without kombu for each job.

kombu's producer builds a message in many steps (the task's headers, the JSON body, its base64 encoding, a delivery
tag, the message's JSON), which cost a submission more than its LPUSH. All of it is the same for every job of a kind's
time limits but three UUIDs: the job id (the task's argument, and in its ``argsrepr``), the task id (``id``,
``root_id``, ``correlation_id``) and kombu's delivery tag. So kombu builds the message once, with UUIDs that stand in
for those, and the text around them is kept: a job's message is that text with its own UUIDs put in. A UUID has the
same length and characters as any other, so neither the JSON's escaping nor the body's base64 changes anywhere else:
the text is the one kombu would have written for those ids (checked when the template is made, and by
tests/workers/test_loop_publish.py against kombu's own message for the same ids).
"""

from __future__ import annotations

import base64
import json
import uuid
from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class TaskMessageTemplate:
    """The Redis key (the queue's list) and the message of a job, for :meth:`message`."""

    key: str
    text: str  # the message, as a ``str.format`` template: {job_id}, {task_id}, {delivery_tag}, {body}
    body: str  # the body before its base64 encoding, as a template: {job_id}

    @classmethod
    def of(cls, build: Callable[[str, str], tuple[str, str]]) -> TaskMessageTemplate:
        """The template of the message ``build(job_id, task_id)`` returns as ``(key, text)`` (kombu's LPUSH)."""
        job_id, task_id = str(uuid.uuid4()), str(uuid.uuid4())
        key, text = build(job_id, task_id)
        built = json.loads(text)
        properties, body64 = built["properties"], built["body"]
        if properties.get("body_encoding") != "base64":
            raise ValueError(f"a task message whose body is not base64 ({properties.get('body_encoding')!r})")
        template = cls(key, _slots(text, {job_id: "{job_id}", task_id: "{task_id}",
                                          properties["delivery_tag"]: "{delivery_tag}", body64: "{body}"}),
                       _slots(base64.b64decode(body64).decode(), {job_id: "{job_id}"}))
        if template.message(job_id, task_id, properties["delivery_tag"]) != text:
            raise ValueError("kombu's task message holds its ids where a template cannot put them")
        return template

    def message(self, job_id: str, task_id: str, delivery_tag: str) -> str:
        """The message of a job: the text kombu writes for these ids."""
        body = base64.b64encode(self.body.format(job_id=job_id).encode()).decode()
        return self.text.format(job_id=job_id, task_id=task_id, delivery_tag=delivery_tag, body=body)


def _slots(text: str, slots: dict[str, str]) -> str:
    """``text`` as a ``str.format`` template: its braces doubled, each key of ``slots`` replaced by its slot."""
    text = text.replace("{", "{{").replace("}", "}}")
    for value, slot in slots.items():
        if value not in text:
            raise ValueError(f"kombu's task message does not hold {slot}")
        text = text.replace(value, slot)
    return text
