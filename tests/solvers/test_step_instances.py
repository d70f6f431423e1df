"""The text of one STEP instance is cut from its '#' to its own closing ';' outside strings, whatever the lines: several
instances on a line, one over several lines, CR-only line ends; a ';' in a string (its quotes doubled inside) is no
end. Before, intake and polyhedra cut an instance from its line's start to the newline."""

from __future__ import annotations

import pytest

from plantsolve.solvers.step_file import instance_text, written_attributes

LINE = "#1=IFCPERSON($,'O''Neil; Jr.',$,$,$,$,$,$);#2=IFCDIRECTION((1.,0.,0.));\r#3=IFCLABEL('a;b'"


@pytest.mark.parametrize("as_bytes", [False, True], ids=["str", "bytes"])
def test_an_instance_ends_at_its_own_semicolon_outside_strings(as_bytes):
    text = LINE.encode() if as_bytes else LINE
    first = instance_text(text, 0)
    assert first == text[:text.index(b";#2" if as_bytes else ";#2") + 1]
    second = instance_text(text, text.index(b"#2" if as_bytes else "#2"))
    assert second == (b"#2=IFCDIRECTION((1.,0.,0.));" if as_bytes else "#2=IFCDIRECTION((1.,0.,0.));")
    assert instance_text(text, text.index(b"#3" if as_bytes else "#3")) is None  # the text ends before its ';'


def test_an_instance_over_several_lines_is_whole_and_counted():
    text = "#5=IFCCOLUMN('2O2Fr$t4X7Zf8NOew3FLOH',\n  #4,'C',$,$,\n  #20,#30,$);\n#6=IFCWALL();"
    instance = instance_text(text, 0)
    assert instance == text[:text.index("\n#6")]
    assert written_attributes(instance) == 8 and written_attributes(instance_text(text, text.index("#6"))) == 0
    assert written_attributes(instance_text(LINE, 0)) == 8  # the string's ';' and doubled quote are one value
