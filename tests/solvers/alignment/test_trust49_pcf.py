"""PCF mistakes, a fourth round: an item of two ends that lost one END-POINT line is held and named with its lines
(it was read as a set-on item of fewer ports: an elbow became an olet, a tee an 'other' of two ports, aligned as if
whole, the pipe it joins left open without a word); the other mistakes of the round keep their answers."""

from __future__ import annotations

import random
import re

import pytest

from plantsolve.solvers.alignment.pcf import interpret_pcf
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import StoredInput
from tests.conftest import REPO

LADDER = (REPO / "examples" / "alignment" / "ladder.pcf").read_text()


def _without(line_start: str) -> str:
    i = LADDER.index(line_start)
    return LADDER[:i] + LADDER[LADDER.index("\n", i) + 1:]


def _notes(text: str) -> dict:
    return {code: details for code, _, details, _ in interpret_pcf(text, None).notes}


@pytest.mark.parametrize("lost, item, line, left", [
    ("    END-POINT 1003152.393751757", "N1-1", 22, 24),  # a TEE's first END-POINT
    ("    END-POINT 1000146.9120824243", "N0-1", 11, 13),  # an ELBOW's first
    ("    END-POINT 999996.293358132", "N0-1", 11, 13),  # an ELBOW's second
])
def test_an_item_of_two_ends_with_one_end_point_line_is_held_naming_its_lines(lost, item, line, left):
    held = _notes(_without(lost))["pcf_items_held"]["items"]
    assert [(h["id"], h["line"]) for h in held] == [(item, line)]
    keyword = LADDER.splitlines()[line - 1]
    assert held[0]["reason"] == (f"{'an' if keyword[0] in 'AEIOU' else 'a'} {keyword} has two END-POINT lines, "
                                 f"this one 1 (line {left}): the other was lost, and what it joins there is not "
                                 "connected to it")


def test_the_whole_ladder_holds_nothing():
    assert "pcf_items_held" not in _notes(LADDER)


def _components(text: str) -> tuple[list[str], list[str]]:
    blocks = [b for b in re.split(r"(?m)^(?=\S)", text) if b.strip()]
    head = [b for b in blocks if b.split()[0] in ("ISOGEN-FILES", "UNITS-BORE", "UNITS-CO-ORDS", "PIPELINE-REFERENCE")]
    return head, [b for b in blocks if b not in head]


def test_shuffled_components_read_to_the_same_request():
    head, items = _components(LADDER)
    shuffled = items[:]
    random.Random(1).shuffle(shuffled)
    assert shuffled != items

    def components(text: str) -> dict:
        request = parse_upload(StoredInput.from_bytes("ladder.pcf", text.encode()), None)
        return {c.id: c.model_dump() for c in request.components}

    assert components("".join(head + shuffled)) == components(LADDER)
