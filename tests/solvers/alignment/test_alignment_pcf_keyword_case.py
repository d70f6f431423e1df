"""A PCF written with its keywords in lower or mixed case: the PCF reader takes keywords in any case, and the intake's
check for 'a file of another kind' now does too — it refused such a file as 'no PCF (not one PCF keyword in it)'."""

from __future__ import annotations

import pytest

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
