"""PCF and JSON uploads, artifacts, and input validation (422 naming the field)."""

import json
from pathlib import Path

import numpy as np
import pytest

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment import SPEC
from plantsolve.solvers.alignment.artifacts import render_artifacts
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.alignment.validation import check_input
from plantsolve.solvers.base import InputRejected, StoredInput

from alignment_cases import conn, elbow, pipe, port, request

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "alignment"

PCF = """ISOGEN-FILES ISOGEN.FLS
UNITS-BORE MM
UNITS-CO-ORDS MM
PIPELINE-REFERENCE 100-CW-1001
    PIPING-SPEC A1
PIPE
    END-POINT 0.0000 0.0000 0.0000 100.0000
    END-POINT 1000.8000 0.4000 0.0000 100.0000
    ITEM-CODE PIPE-100
ELBOW
    END-POINT 1002.0000 0.0000 0.0000 100.0000 BW
    END-POINT 1152.0000 150.0000 0.0000 100.0000 BW
    CENTRE-POINT 1152.0000 0.0000 0.0000
    SKEY ELBW
TEE
    END-POINT 1150.0000 1150.0000 0.0000 100.0000
    END-POINT 1150.0000 1450.0000 0.0000 100.0000
    CENTRE-POINT 1150.0000 1300.0000 0.0000
    BRANCH1-POINT 1300.0000 1300.0000 0.0000 100.0000
    SKEY TEBW
PIPE
    END-POINT 1150.0000 150.0000 0.0000 100.0000
    END-POINT 1150.6000 1149.0000 0.0000 100.0000
VALVE
    END-POINT 1300.0000 1300.0000 0.0000 100.0000
    END-POINT 1600.0000 1300.3000 0.0000 100.0000
    SKEY VGFL
CAP
    END-POINT 1150.0000 1450.0000 0.0000 100.0000
MATERIALS
ITEM-CODE PIPE-100
    DESCRIPTION PIPE SMLS
"""


def test_extensions():
    assert SPEC.upload_extensions == (".pcf", ".json")


def test_pcf_parse_align_write_parse_round_trip():
    req = parse_upload(StoredInput.from_bytes("line.PCF", PCF.encode()), {"fixed_components": ["PIPE-1"]})
    # the pipe's ITEM-CODE is unique in this file, so it is the pipe's id; the others are positional
    assert [c.id for c in req.components] == ["PIPE-100", "ELBOW-2", "TEE-3", "PIPE-4", "VALVE-5", "CAP-6"]
    assert req.components[0].fixed  # fixed by its positional alias
    assert len(req.connections) == 5
    tee = req.components[2]
    np.testing.assert_allclose([p.direction for p in tee.ports], [[0, -1, 0], [0, 1, 0], [1, 0, 0]])
    np.testing.assert_allclose(req.components[5].ports[0].direction, [0, -1, 0])  # cap faces its tee
    assert req.components[0].radius == 50.0
    # the request (with its PCF source) survives the JSON round trip of the job queue
    req = AlignmentRequest.model_validate_json(req.model_dump_json(by_alias=True))
    solved = solve(req)
    res = solved.result
    assert res.converged and not res.cut_connections
    arts = {a.name: a for a in render_artifacts(req, solved)}
    text = arts["aligned.pcf"].data.decode()
    again = parse_upload(StoredInput.from_bytes("aligned.pcf", text.encode()), None)
    assert [c.id for c in again.components] == [c.id for c in req.components]
    assert [(c.from_, c.to) for c in again.connections] == [(c.from_, c.to) for c in req.connections]
    for c_out, c_again in zip(res.components, again.components):  # printed with the file's 4 decimals
        np.testing.assert_allclose([p.position for p in c_again.ports], [p.position for p in c_out.ports],
                                   rtol=0, atol=0.5e-4 + 1e-9)
    by_id = {c.id: c for c in again.components}
    tol = res.report.details["position_tolerance"]
    for c in again.connections:
        gap = np.subtract(by_id[c.from_[0]].ports[c.from_[1]].position, by_id[c.to[0]].ports[c.to[1]].position)
        assert np.linalg.norm(gap) <= tol
    # untouched attributes and the tie-in's lines are kept verbatim
    lines = text.splitlines()
    for keep in ("    PIPING-SPEC A1", "    SKEY ELBW", "    ITEM-CODE PIPE-100", "    DESCRIPTION PIPE SMLS",
                 "    END-POINT 0.0000 0.0000 0.0000 100.0000", "    END-POINT 1000.8000 0.4000 0.0000 100.0000"):
        assert keep in lines
    assert any(line.startswith("    END-POINT ") and line.endswith(" 100.0000 BW") for line in lines)
    assert len(lines) == len(PCF.splitlines())


def test_json_model_writes_a_pcf_that_parses_back():
    req = json.loads((EXAMPLES / "ladder.json").read_text())
    req = AlignmentRequest.model_validate(req)
    solved = solve(req)
    arts = render_artifacts(req, solved)
    names = [a.name for a in arts]
    assert len(names) == len(set(names)) == 2
    media = {a.name: a.media_type for a in arts}
    assert media["gaps.png"] == "image/png" and media["aligned.pcf"].startswith("text/plain")
    assert next(a for a in arts if a.name == "gaps.png").data[:8] == b"\x89PNG\r\n\x1a\n"
    back = parse_upload(StoredInput.from_bytes("aligned.pcf", next(a for a in arts if a.name == "aligned.pcf").data), {"connection_tolerance": 1e-6})
    assert len(back.components) == len(req.components)
    assert len(back.connections) == len(req.connections)  # every closed joint is found at zero distance


def test_example_pcf_and_json_upload():
    req = parse_upload(StoredInput.from_bytes("ladder.pcf", (EXAMPLES / "ladder.pcf").read_bytes()), {"fixed_components": ["ELBOW-1"]})
    assert req.components[0].fixed
    assert solve(req).result.converged
    body = json.loads((EXAMPLES / "ladder.json").read_text())
    body["options"].pop("method")  # the file's own 'direct' and the form's other method: refused naming both
    req2 = parse_upload(StoredInput.from_bytes("LADDER.JSON", json.dumps(body).encode()),
                        {"method": "dual_quaternion", "max_iterations": 10})
    assert req2.options.method == "dual_quaternion"


@pytest.mark.parametrize(
    "name, content, fragment",
    [
        ("x.json", b"{not json", "invalid JSON"),
        ("x.json", b"[1, 2]", "object"),
        ("x.pcf", b"ISOGEN-FILES X\nUNITS-CO-ORDS MM\n", "no PCF components"),
        ("x.pcf", b"PIPE\n    END-POINT 0 0 zero 10\n    END-POINT 1 0 nan 10\n", "cannot read"),
    ],
)
def test_bad_uploads_name_the_file(name, content, fragment):
    with pytest.raises(InputRejected) as exc:
        parse_upload(StoredInput.from_bytes(name, content), None)
    assert exc.value.errors[0].loc[0] == "file"
    assert fragment in str(exc.value)


def test_json_upload_validation_errors_carry_the_path():
    with pytest.raises(InputRejected) as exc:
        parse_upload(StoredInput.from_bytes("x.json", json.dumps({"components": [{"id": "a", "kind": "pipe", "ports": []}]}).encode()), None)
    assert exc.value.errors[0].loc[:3] == ("file", "components", 0)


def _base():
    return [pipe("P", [0, 0, 0], [1000, 0, 0]), elbow("E", [1150, 0, 0], [-1, 0, 0], [0, 1, 0])]


@pytest.mark.parametrize(
    "mutate, loc",
    [
        (lambda c, k: k.append(conn("X", 0, "E", 0)), ("connections", 1, "from")),
        (lambda c, k: k.append(conn("E", 5, "P", 0)), ("connections", 1, "from")),
        (lambda c, k: k.append(conn("P", 0, "E", 0)), ("connections", 1, "to")),
        (lambda c, k: c[1]["ports"][1].update(direction=[0, 0, 0]), ("components", 1, "ports", 1, "direction")),
        (lambda c, k: c[0]["ports"][1].update(position=[1000, 30, 0]), ("components", 0, "ports")),
        (lambda c, k: c.append({"id": "T", "kind": "fitting", "type": "tee", "ports": [port([0, 5, 0], [0, 1, 0])] * 2}),
         ("components", 2, "ports")),
        (lambda c, k: c.append(dict(c[0])), ("components", 2, "id")),
        (lambda c, k: k.append(conn("E", 1, "E", 0)), ("connections", 1, "to")),
    ],
)
def test_bad_input_names_the_field(mutate, loc):
    comps, conns = _base(), [conn("P", 1, "E", 0)]
    mutate(comps, conns)
    req = request(comps, conns)
    with pytest.raises(InputRejected) as exc:
        check_input(req)
    assert loc in [e.loc for e in exc.value.errors]
    assert SPEC.check_input.target is check_input  # the job domain runs it at submission; solve does not again


def test_non_finite_values_are_rejected_by_the_schema():
    from pydantic import ValidationError

    comps = _base()
    comps[0]["ports"][0]["direction"] = [float("nan"), 0, 0]
    with pytest.raises(ValidationError) as exc:
        request(comps, [])
    assert exc.value.errors()[0]["loc"][:5] == ("components", 0, "ports", 0, "direction")


def test_tolerance_profiles():
    from plantsolve.solvers.alignment.model import resolve_tolerances

    r = request(_base(), [], tolerance_profile="aveva_e3d")
    assert resolve_tolerances(r) == (1.0, 0.01, 0.0)  # (position, angle, rounding of printed coordinates)
    r = AlignmentRequest.model_validate({**r.model_dump(by_alias=True), "units": "m"})
    assert resolve_tolerances(r) == pytest.approx((1e-3, 0.01, 0.0))
    r = request(_base(), [], tolerance_profile="revit")
    assert resolve_tolerances(r)[0] == pytest.approx(304.8e-9)
    r = request(_base(), [], tolerance_profile="revit", position_tolerance=0.5, angle_tolerance=1.0)
    assert resolve_tolerances(r) == pytest.approx((0.5, np.radians(1.0), 0.0))
    assert resolve_tolerances(request(_base(), [])) == (1e-10, 1e-10, 0.0)  # 'auto' on JSON: exact coordinates


def test_progress_is_reported_and_cancellation_propagates():
    from plantsolve.solvers.base import Cancelled

    seen = []
    req = request(_base(), [conn("P", 1, "E", 0)])
    solve(req, lambda f, m="": seen.append(f))
    assert seen and all(0 <= f <= 1 for f in seen)

    def cancel(f, m=""):
        raise Cancelled()

    with pytest.raises(Cancelled):
        solve(req, cancel)


PCF_INCH = """UNITS-BORE INCH
UNITS-CO-ORDS MM
PIPE
    END-POINT -1000.0 0.0 0.0 4
    END-POINT -150.0 0.0 0.0 4
CROSS
    END-POINT -150.0 0.0 0.0 4
    END-POINT 150.0 0.0 0.0 4
    CENTRE-POINT 0.0 0.0 0.0
    BRANCH1-POINT 0.0 150.0 0.0 4
    BRANCH2-POINT 0.0 -150.0 0.0 4
REDUCER-CONCENTRIC
    END-POINT 150.0 0.0 0.0 4
    END-POINT 400.0 0.0 0.0 3
OLET
    CENTRE-POINT 0.0 0.0 500.0
    BRANCH1-POINT 0.0 0.0 600.0 2
"""


def test_pcf_cross_reducer_olet_and_bore_units():
    req = parse_upload(StoredInput.from_bytes("x.pcf", PCF_INCH.encode()), None)
    kinds = [(c.id, c.kind, c.type, len(c.ports)) for c in req.components]
    assert kinds == [("PIPE-1", "pipe", None, 2), ("CROSS-2", "fitting", "cross", 4),
                     ("REDUCER-CONCENTRIC-3", "fitting", "reducer", 2), ("OLET-4", "fitting", "olet", 1)]
    assert req.components[0].radius == pytest.approx(2 * 25.4)  # 4 inch bore, mm co-ordinates
    np.testing.assert_allclose([p.direction for p in req.components[1].ports], [[-1, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0]])
    np.testing.assert_allclose(req.components[3].ports[0].direction, [0, 0, 1])
    assert [(c.from_, c.to) for c in req.connections] == [(("PIPE-1", 1), ("CROSS-2", 0)), (("CROSS-2", 1), ("REDUCER-CONCENTRIC-3", 0))]
