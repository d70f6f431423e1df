"""When a LEGO model's answer is no answer: the verdicts a parts model's report can hold.

- ``rigidity_not_determined`` (NOT DETERMINED): the parts not in the catalogue, with the placements the reader could
  not read, are at least half of the model (its known parts no majority), so ``dof``, ``rigid`` and the pieces,
  counted over the known parts only, say nothing of the model: ``rigid`` is null. A flexible element an editor draws
  as a chain of short segments (an LSynth hose or rope, a hose of segments 754) is one element, not hundreds of parts
  (:func:`unknown_elements`).
- ``one_piece_not_determined`` (NOT DETERMINED): a model is one build unless its drawing says otherwise, so known parts
  that come apart into pieces besides the held sub-builds (a minifigure, a whole sub-model standing clear) and the
  separate builds the drawing places apart (a second vehicle, spares laid aside) are a build that falls apart as
  analysed: either loose as drawn, or held by a joint the catalogue does not know. Which of the two cannot be told
  from the drawing (official sets that are one build still come apart so, at joints the catalogue lacks), so
  ``rigid`` is null, not false; the ``floating_parts`` and ``separate_pieces`` warnings name each piece with its
  nearest miss.
- ``submodels_missing`` (NOT DETERMINED) when the file places sub-models it does not hold (an ``.mpd`` whose ``0 FILE``
  section was lost, an ``.ldr`` sent without its sub-model files): the parts they hold are in no count, and what they
  would join or leave loose cannot be told, so ``rigid`` is null whatever the parts present make.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.rigidity import Piece
from plantsolve.solvers.rigidity.upload import MAX_PARTS

# LDU: half a plate's height. Two solid parts of one number whose origins are closer than this overlap, so parts so
# placed are segments of one flexible element (LSynth draws its hoses and ropes 1-3 LDU a segment).
SEGMENT_STEP = 4.0
KNOWN_MAJORITY = 0.5  # the share of the model's elements the known parts must exceed for a verdict on the model


def unknown_elements(numbers: Sequence[str], positions: np.ndarray) -> int:
    """How many elements the unknown parts (``numbers``, origins ``positions``) are: parts of one number chained
    with origins within SEGMENT_STEP of each other count once."""
    if not len(numbers):
        return 0
    positions = np.asarray(positions, float).reshape(-1, 3)
    count = 0
    for number in set(numbers):
        at = positions[[k for k, n in enumerate(numbers) if n == number]]
        # parts in one cell of side SEGMENT_STEP / sqrt(3) are within SEGMENT_STEP of each other, so one stands for
        # them all: the pairs are then bounded by the cells around each, not quadratic in parts placed at one spot
        # (20,000 copies of a part at one origin gave 2e8 pairs, 10 GB)
        _, first = np.unique(np.floor(at * (np.sqrt(3.0) / SEGMENT_STEP)), axis=0, return_index=True)
        at = at[np.sort(first)]
        pairs = cKDTree(at).query_pairs(SEGMENT_STEP, output_type="ndarray").reshape(-1, 2)
        links = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(at), len(at)))
        count += connected_components(links, directed=False)[0]
    return int(count)


def _count(n: int, most: int) -> str:
    return f"more than {most}" if n > most else str(n)


def coverage_verdict(known: int, unknown_numbers: Sequence[str], unknown_positions: np.ndarray,
                     not_read: int = 0, past_limit: int = 0, most: int = MAX_PARTS) -> Diagnostic | None:
    """``rigidity_not_determined`` when the known parts are no majority of the model's elements: those the catalogue
    lacks, the parts the placements the reader skipped would have placed (``not_read``: a matrix that scales, a
    position not finite, a line cut, a sub-model nested too deep; a sub-model's line all its parts) and those past
    the reader's limit of ``most`` parts (``past_limit``), each one element; a count above ``most`` is said as such."""
    if not len(unknown_numbers) and not not_read and not past_limit:
        return None
    elements = unknown_elements(unknown_numbers, unknown_positions)
    unseen = not_read + past_limit
    share = (elements + unseen) / (known + elements + unseen)
    if share < 1.0 - KNOWN_MAJORITY:
        return None
    counted = [(f"{len(unknown_numbers)} part(s) not in the catalogue, {elements} element(s) counting a chain of "
                "segments as one")] if len(unknown_numbers) else []
    counted += [(f"{_count(not_read, most)} part(s) placed by lines that could not be read (skipped_lines; a "
                 "sub-model's line counts its parts)")] if not_read else []
    counted += [f"{_count(past_limit, most)} part(s) past the reader's limit of {most} parts, not read"] \
        if past_limit else []
    return Diagnostic(
        code="rigidity_not_determined", message=f"rigidity not determined: the parts "
        f"{'not in the catalogue or not read' if unseen else 'not in the catalogue'} are {share:.0%} of the model "
        f"({'; '.join(counted)}; {known} known part(s)), so dof, rigid and the pieces, counted over the known parts "
        f"only, cover no majority of it (rigid is null; a verdict needs the known parts above {KNOWN_MAJORITY:.0%})",
        details={"unknown_share": round(share, 4), "unknown_parts": len(unknown_numbers),
                 "unknown_elements": elements, "placements_not_read": not_read,
                 "parts_past_limit": past_limit, "known_parts": known,
                 "known_share_needed": KNOWN_MAJORITY})


def one_piece_verdict(found: Sequence[Piece]) -> Diagnostic | None:
    """``one_piece_not_determined`` when pieces besides the largest are neither held sub-builds nor drawn apart."""
    loose = [pc for pc in found[1:] if pc.sub_build is None and not pc.drawn_apart]
    if not loose:
        return None
    singles = sum(len(pc.parts) == 1 for pc in loose)
    return Diagnostic(
        code="one_piece_not_determined", message=f"whether the model is one piece is not determined: besides the largest piece ({len(found[0].parts)} parts), "
        f"{len(loose)} piece(s) ({singles} single part(s), {len(loose) - singles} of several parts) are joined to "
        "nothing else, though no held sub-build (a minifigure, a whole sub-model standing clear) and not drawn apart "
        "(they touch the build, or lie within a slip of a mate): the build falls apart as analysed, either loose as "
        "drawn or held by a joint the catalogue does not know (floating_parts and separate_pieces name each with "
        "its nearest miss); rigid is null and dof counts 6 for each",
        details={"pieces": len(loose), "single_parts": singles, "parts": sum(len(pc.parts) for pc in loose)})


def names_lines(missing: object) -> bool:
    """Whether ``missing`` is what the LDraw reader writes as ``source.missing_submodels``: each sub-model's name ->
    the lines placing it."""
    return isinstance(missing, dict) and all(
        isinstance(name, str) and isinstance(lines, list) and all(type(n) is int for n in lines)
        for name, lines in missing.items())


def missing_submodels_verdict(missing: object, count: object = None) -> Diagnostic | None:
    """``submodels_missing`` when the file places sub-models it does not hold (``missing``: name -> the lines placing
    it, the first of them when the reader listed only so many; ``count``: how many there are, as the reader counted;
    a value of another shape, which intake refuses in a written request, says nothing the verdict can name)."""
    if not missing or not names_lines(missing):
        return None
    total = max(count, len(missing)) if type(count) is int else len(missing)

    def placed(name: str, lines: list[int]) -> str:
        if not lines:
            return repr(name)
        return f"{name!r} (line{'s' if len(lines) > 1 else ''} {', '.join(map(str, lines[:3]))}" \
               f"{' …' if len(lines) > 3 else ''})"

    named = ", ".join(placed(name, lines) for name, lines in list(missing.items())[:5])
    return Diagnostic(
        code="submodels_missing", message=f"rigidity not determined: the file places {total} sub-model(s) "
        f"it does not hold — {named}{' and more' if total > 5 else ''}"
        f"{f' ({len(missing)} listed in details)' if total > len(missing) else ''}: their parts are not analysed, and what "
        "they would join or leave loose cannot be told, so dof and the pieces are of the parts present only (rigid is "
        "null); send the model with its sub-models as one .mpd",
        details={"missing_submodels": sorted(missing), "lines": {name: lines for name, lines in missing.items()}})
