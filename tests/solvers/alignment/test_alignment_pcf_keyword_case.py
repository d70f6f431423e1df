"""PCF mistakes. Keywords in lower or mixed case: the reader takes them in any case, and the intake's check for 'a
file of another kind' now does too (it refused such a file as 'no PCF (not one PCF keyword in it)'). A TEE whose
BRANCH1-POINT line was lost: read as a two-port item, its branch pipe was left unjoined without a word; it is now
held and named."""

from __future__ import annotations

import pytest

from plantsolve.solvers.alignment.pcf import interpret_pcf
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import InputRejected, StoredInput
from tests.conftest import REPO

LADDER = (REPO / "examples" / "alignment" / "ladder.pcf").read_text()


def ports(text: str) -> list:
    request = parse_upload(StoredInput.from_bytes("ladder.pcf", text.encode()), None)
    return sorted((c.id.upper(), [p.position for p in c.ports]) for c in request.components)


def test_a_pcf_in_lower_case_reads_as_the_same_pcf_in_upper_case_and_lower_case_words_are_no_pcf():
    upper = ports(LADDER)
    assert len(upper) == 19
    assert ports(LADDER.lower()) == upper
    with pytest.raises(InputRejected, match=r"this is no PCF \(not one PCF keyword in it\), it holds text beginning "
                                            r"'pipe dreams'"):
        parse_upload(StoredInput.from_bytes("notes.pcf", b"pipe dreams\nend of story\n"), None)


BRANCH = "    BRANCH1-POINT 1002998.967861063 200151.69264963636 10001.3613400916 100.0000\n"


def test_a_tee_whose_branch_line_was_lost_is_held_and_named():
    assert BRANCH in LADDER
    interpretation = interpret_pcf(LADDER.replace(BRANCH, ""), None)
    held = {code: details for code, _, details, _ in interpretation.notes}["pcf_items_held"]["items"]
    assert [(item["id"], item["line"]) for item in held] == [("N1-0", 16)]
    assert held[0]["reason"] == ("a TEE has 1 BRANCH-POINT line(s) beside its two END-POINTs, this one 0: the branch "
                                 "line was lost, and the pipe it joins is not connected to it")
