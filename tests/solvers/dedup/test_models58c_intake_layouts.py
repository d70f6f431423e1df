"""Intake reads instances however a file lays them out: several on a line, CR-only line ends, the whole DATA section on
one line (main accepted these; models58 refused them as "#1=IFCPERSON is written with 12 attributes", the instance cut
from its line's start to the newline). A file of another schema is still refused naming its first misfit and its
line, also after a chunk without ';' (a point list of megabytes), whose lines are counted; a context's definition
holding a ';' in a string is judged whole; the world check runs on the first chunk only and judges a few contexts."""

from __future__ import annotations

import pytest

from plantsolve.solvers.dedup import validation
from tests.conftest import REPO
from tests.solvers.dedup.support import intake_refusal, intake_text

ZOO = (REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc").read_text()
TUNNEL = (REPO / "examples" / "dedup" / "tunnel_3rings.ifc").read_text()


_intake, _refused = intake_text, intake_refusal


def _two_per_line(text: str) -> str:
    head, data = text.split("DATA;\n", 1)
    body, tail = data.split("ENDSEC;", 1)
    lines = body.splitlines()
    return head + "DATA;\n" + "\n".join("".join(lines[i:i + 2]) for i in range(0, len(lines), 2)) + "\nENDSEC;" + tail


LAYOUTS = {"two per line": _two_per_line, "CR only": lambda t: t.replace("\n", "\r"),
           "one line": lambda t: t.replace("\n", "")}


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("text", [ZOO, TUNNEL], ids=["IFC2X3", "IFC4"])
def test_a_valid_model_passes_intake_however_its_instances_are_laid_out(text, layout):
    _intake(LAYOUTS[layout](text))  # before: refused, "#1=IFCPERSON is written with 12 attributes"


def test_a_misfit_two_instances_a_line_is_named_with_its_own_line():
    text = _two_per_line(ZOO.replace("FILE_SCHEMA(('IFC2X3'))", "FILE_SCHEMA(('IFC4'))"))
    line = text[:text.index("#955=IFCCOLUMN(")].count("\n") + 1
    assert _refused(text).startswith(f"line {line}: #955=IFCCOLUMN is written with 8 attributes, and IfcColumn has 9")


def test_the_line_of_a_misfit_after_a_chunk_without_a_semicolon_counts_that_chunks_lines():
    points = ",\n".join(f"({k}.,0.,0.)" for k in range(160_000))  # 2.4 MB: a whole 1 MB chunk inside it
    text = ZOO.replace("FILE_SCHEMA(('IFC2X3'))", "FILE_SCHEMA(('IFC4'))").replace(
        "DATA;\n", f"DATA;\n#990000=IFCCARTESIANPOINTLIST3D(({points}));\n", 1)
    line = text[:text.index("#955=IFCCOLUMN(")].count("\n") + 1
    assert _refused(text).startswith(f"line {line}: #955=IFCCOLUMN")  # before: ~70,000 lines short


def test_a_context_with_a_semicolon_in_its_identifier_is_judged_whole():
    context = "#13=IFCGEOMETRICREPRESENTATIONCONTEXT($,'Model',3,1.E-05,#12,$);"
    assert context in ZOO
    bad = ZOO.replace("#9=IFCCARTESIANPOINT((0.,0.,0.));", "#9=IFCCARTESIANPOINT((1.E308,0.,0.));")
    _intake(ZOO.replace(context, context.replace("$,'Model'", "'3D; main','Model'")))
    msg = _refused(bad.replace(context, context.replace("$,'Model'", "'3D; main','Model'")))
    # before: accepted, the definition cut at the string's ';' and passed over
    assert msg.startswith("the model's world coordinate system cannot place") and "#9=IfcCartesianPoint" in msg


def test_the_world_check_runs_on_the_first_chunk_alone_even_without_line_ends(monkeypatch):
    calls = []
    monkeypatch.setattr(validation, "refuse_unplaceable_world", lambda text, schema, blanked=None: calls.append(len(text)))
    monkeypatch.setattr(validation, "refuse_other_schema", lambda *args: None)  # the flag alone tested
    filler = "".join(f"#{900000 + k}=IFCCARTESIANPOINT((0.,0.,{k}.));" for k in range(40_000))  # 1.4 MB
    _intake(ZOO.replace("DATA;\n", "DATA;\n" + filler, 1).replace("\n", "\r"))
    assert len(calls) == 1  # before: once a chunk, a CR-only or one-line file never past its 'first' line


def test_a_file_of_thousands_of_contexts_has_a_few_judged(monkeypatch):
    judged = []
    monkeypatch.setattr(validation, "world_coordinate_problem", lambda world, text: judged.append(world) or None)
    contexts = "".join(f"#{k}=IFCCARTESIANPOINT((0.,0.,0.));#{k + 1}=IFCAXIS2PLACEMENT3D(#{k},$,$);"
                       f"#{k + 2}=IFCGEOMETRICREPRESENTATIONCONTEXT($,'Model',3,1.E-05,#{k + 1},$);\n"
                       for k in range(1000, 4000, 3))
    validation.refuse_unplaceable_world(contexts.encode(), "IFC4")
    assert len(judged) == validation.MAX_CONTEXTS  # before: each of the 1,000, each a search of the whole text
