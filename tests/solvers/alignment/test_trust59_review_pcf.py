"""Review of trust59a's PCF rules: a short pipe "fills a gap" only when each of its ends meets an item the other end
does not. A PIPE whose END-POINT was typed twice at a joint of two other items (a pipe and a weld written at one
point, as E3D writes welds) met two items at each end and was taken for a gap filler: its far item, left open, went
unsaid."""

import pytest

from plantsolve.solvers.alignment.pcf import interpret_pcf

TYPED_TWICE = ("UNITS-BORE MM\nUNITS-CO-ORDS MM\n"
               "PIPE\n    END-POINT 0.0 0.0 0.0 100.0\n    END-POINT 1000.0 0.0 0.0 100.0\n"
               "WELD\n    END-POINT 1000.0 0.0 0.0 100.0\n    END-POINT 1000.0 0.0 0.0 100.0\n"
               "PIPE\n    END-POINT 1000.0 0.0 0.0 100.0\n    END-POINT {far} 0.0 0.0 100.0\n"
               "ELBOW\n    END-POINT 2000.0 0.0 0.0 100.0\n    END-POINT 2152.4 152.4 0.0 100.0\n"
               "    CENTRE-POINT 2152.4 0.0 0.0\n"
               "PIPE\n    END-POINT 2152.4 152.4 0.0 100.0\n    END-POINT 2152.4 1152.4 0.0 100.0\n")


def _warnings(text: str) -> dict:
    return {code: details for code, _, details, level in interpret_pcf(text, {}).notes if level == "warning"}


@pytest.mark.parametrize("far", ["1000.0", "1000.1"])
def test_a_pipe_typed_twice_where_a_weld_meets_a_pipe_is_still_named(far):
    (found,) = _warnings(TYPED_TWICE.format(far=far))["pcf_zero_length_pipe"]["items"]
    assert found["line"] == 9 and found["length"] == pytest.approx(float(far) - 1000.0)


def test_the_same_file_as_meant_names_no_pipe():
    assert "pcf_zero_length_pipe" not in _warnings(TYPED_TWICE.format(far="2000.0"))


def test_the_units_option_refusal_names_the_files_units_not_an_items_own():
    from plantsolve.solvers.alignment.upload import parse_upload
    from plantsolve.solvers.base import InputRejected, StoredInput

    text = ("PIPELINE-REFERENCE LINE-100\n    UNITS-BORE INCH\n    UNITS-CO-ORDS MM\n"
            + TYPED_TWICE.format(far="2000.0").split("\n", 2)[2].replace(
                "WELD\n", "WELD\n    UNITS-BORE MM\n", 1))
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("line.pcf", text.encode()), {"units": "in"})
    msg = refused.value.errors[0].msg
    assert "UNITS-BORE INCH (line 2), UNITS-CO-ORDS MM (line 3)." in msg and "UNITS-BORE MM" not in msg
