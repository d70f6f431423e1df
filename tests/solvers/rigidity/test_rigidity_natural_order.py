"""Part ids order naturally (L7 before L11) and totally: a superscript digit is a letter to the order (it was
an int() crash that failed the job), and ids equal as numbers (p01, p1) keep one order whatever the input's."""

from __future__ import annotations

from plantsolve.solvers.rigidity.assembly import natural_order


def test_ids_order_by_their_numbers_then_by_themselves():
    ids = ["L11", "p1", "brick²", "L7", "p01", "²", "x1²", "٣"]
    ordered = sorted(ids, key=natural_order)
    assert ordered == sorted(reversed(ids), key=natural_order)  # no tie is left to the input's order
    assert ordered.index("L7") < ordered.index("L11")
    assert ordered.index("p01") < ordered.index("p1")  # equal as numbers: then as text
    assert natural_order("x1²")[0] == [(-1, "x"), (1, ""), (-1, "²")]
