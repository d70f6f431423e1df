"""A STEP text's strings and comments are blanked to spaces of their own length, line ends kept, so every scan of the
instances finds the same definitions and lines as a parser: none inside a string or comment; one left open at the
text's end is blanked to it and named; a chunk cut inside a long instance is carried on in the string or comment it
was cut in, never between a CR and its LF."""

from __future__ import annotations

import pytest

from plantsolve.solvers.step_file import (
    blank_strings_and_comments,
    carried_from,
    instance_text,
    left_open,
    line_ends,
)

TEXT = "#1=A('O''Neil;#2=B',/* c;\r\n#3=C( */$);\r#4=D('/*');/* '; */#5=E($);"


@pytest.mark.parametrize("as_bytes", [False, True], ids=["str", "bytes"])
def test_strings_and_comments_become_spaces_of_their_length_with_their_line_ends(as_bytes):
    text = TEXT.encode() if as_bytes else TEXT
    blanked = blank_strings_and_comments(text)
    expected = "#1=A(" + " " * 14 + "," + " " * 5 + "\r\n" + " " * 8 + "$);\r#4=D(    );" + " " * 8 + "#5=E($);"
    assert blanked == (expected.encode() if as_bytes else expected)
    assert line_ends(blanked) == line_ends(text) == 2  # CR LF one line end, CR alone another


def test_an_instance_ends_at_its_own_semicolon_given_the_blanked_text_or_not():
    blanked = blank_strings_and_comments(TEXT)
    first = TEXT[:TEXT.index(";\r#4") + 1]
    assert instance_text(TEXT, 0) == instance_text(TEXT, 0, blanked) == first
    fourth = TEXT.index("#4")
    assert instance_text(TEXT, fourth, blanked) == "#4=D('/*');"
    assert instance_text("#9=F('never;closed", 0) is None


@pytest.mark.parametrize("text, at", [("#1=A('x');", None), ("#1=A('x''", 5), ("#1=A($);/* c", 8),
                                      ("#1=A('/*');", None), ("", None)])
def test_a_string_or_comment_left_open_is_found_where_it_opens(text, at):
    assert left_open(text) == at


def test_a_chunk_is_carried_on_inside_the_string_or_comment_it_was_cut_in():
    text = b"#1=A('abc''def\r\nghi"
    assert carried_from(text, text.index(b"g")) == (text.index(b"g"), b"'", 5)
    assert carried_from(text, text.index(b"\n")) == (text.index(b"\r"), b"'", 5)  # not between CR and LF
    assert carried_from(text, text.index(b"def") - 1) == (text.index(b"''"), b"'", 5)  # not inside a doubled quote
    comment = b"#1=A($,/* note"
    assert carried_from(comment, len(comment) - 2) == (len(comment) - 2, b"/*", 7)
    assert carried_from(b"#1=A((0.,0.),(1.,", 10) == (10, b"", None)
