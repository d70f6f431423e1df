"""The scan tells the faceted entities apart by their names' 64-bit words, all first words in one sorted search:
names that share their first eight bytes (IFCFACE…, IFCCARTESIANPOINT and its point lists, IFCPOLYLOOP and
IFCPOLYLINE) get each its own code, and any other entity none."""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.dedup import skeleton

DECOYS = (b"IFCCARTESIANPOINTLIST3D", b"IFCCARTESIANPOINTLIST2D", b"IFCFACESURFACE", b"IFCPOLYLINE",
          b"IFCCLOSEDSHELLX", b"IFCFACEBOUNDS", b"IFCFACETEDBREPWITHVOIDS", b"IFCOPENSHELLS", b"IFCFACE",
          b"IFCDIRECTION", b"IFCSHELLBASEDSURFACEMODE", b"IFCCONNECTEDFACESETS")


def _section(names: list[bytes]) -> tuple[np.ndarray, int]:
    """A data section of one line per name (ids from 1, a space after '=' on every third line), and what
    follows it in a file."""
    lines = [b"#%d=%s%s(#%d,'x');\n" % (i, b" " if i % 3 == 0 else b"", name, i + 1)
             for i, name in enumerate(names, start=1)]
    text = b"".join(lines)
    return np.frombuffer(text + b"ENDSEC;\nEND-ISO-10303-21;\n" + b" " * 64, dtype=np.uint8), len(text)


def test_every_name_gets_its_code_and_a_name_that_only_begins_like_one_none():
    rng = np.random.default_rng(4)
    names = list(skeleton.NAMES) * 3 + list(DECOYS) * 3
    names = [names[i] for i in rng.permutation(len(names))]
    seg, length = _section(names)
    got = skeleton._scan(seg, length)
    assert got is not None
    code = got[4]
    want = [skeleton.NAMES.index(n) + 1 if n in skeleton.NAMES else 0 for n in names]
    assert code.tolist() == want


def test_every_name_s_first_word_is_whole():
    # the one search compares first words whole: a name (with its '(') shorter than eight bytes would need a mask
    assert all(len(name) + 1 >= 8 for name in skeleton.NAMES)
