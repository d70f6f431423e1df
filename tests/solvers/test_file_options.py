"""An uploaded request file's ``options`` that is no object (``[]``, ``""``, ``0``, ``null``) is refused naming
``file.options`` whether or not the form sends options too: laid under the form's, it was taken for no options at all
(``body.get("options") or {}`` in each reader), so the same file was refused alone and accepted with a form."""

import json
from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.kinds import load_kinds

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
KINDS = load_kinds(())
FILES = {"tube": ("tube/scan_request.json", {"pipe_radius": 20.0}),
         "perfmap": ("perfmap/n3_fan_map.json", {"map": True}),
         "alignment": ("alignment/ladder.json", {"method": "direct"}),
         "flowmeter": ("flowmeter/meter.json", {}),
         "dedup": (None, {"allow_mirror": True})}


@pytest.mark.parametrize("kind", ["tube", "perfmap", "alignment", "flowmeter"])
@pytest.mark.parametrize("own", [[], "", 0, None, [1]])
def test_a_files_options_that_are_no_object_are_refused_with_form_options_too(kind, own):
    path, form = FILES[kind]
    body = {**json.loads((EXAMPLES / path).read_text()), "options": own}
    form = form or {"nonexistent_but_form": 1}
    with pytest.raises(InputRejected) as refused:
        KINDS[kind].parse_upload(StoredInput.from_bytes("request.json", json.dumps(body).encode()), form)
    assert refused.value.errors[0].loc == ("file", "options"), refused.value.errors
