"""``pcf_notes`` of a request without a source PCF (a JSON request) is no notes: before, it raised TypeError (the
PCF reader was handed None), so every caller had to ask first whether the request has a PCF."""

from __future__ import annotations

import json

from plantsolve.solvers.alignment.pcf import pcf_notes
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.kinds import KINDS
from tests.conftest import REPO

LADDER = REPO / "examples" / "alignment"


def test_a_request_without_a_pcf_has_no_pcf_notes():
    spec = KINDS["alignment"]
    request = spec.parse_upload(StoredInput.from_bytes("ladder.json", (LADDER / "ladder.json").read_bytes()), {})
    assert request.source_pcf is None
    assert pcf_notes(request) == []
    assert pcf_notes(spec.request_model.model_validate(json.loads((LADDER / "ladder.json").read_text()))) == []


def test_a_request_read_from_a_pcf_keeps_its_notes():
    request = KINDS["alignment"].parse_upload(
        StoredInput.from_bytes("ladder.pcf", (LADDER / "ladder.pcf").read_bytes()), {})
    assert request.source_pcf is not None
    notes = pcf_notes(request)
    assert notes and notes == pcf_notes(request.model_copy())  # said again from the text, the same each time
    assert all(level in ("warning", "detail") for _, _, _, level in notes)
