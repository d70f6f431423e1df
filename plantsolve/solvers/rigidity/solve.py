"""The rigidity job: build an :class:`Assembly` from the request, then the exact pass, the generic
count, collisions and docking."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

from plantsolve.schemas.common import Diagnostic, Report
from plantsolve.schemas.rigidity import (Collision, DockingCandidate, JointResult, LoneMotion, PartJoints, Piece,
                                         RigidityRequest, RigidityResult, UnknownPart)
from plantsolve.solvers.base import Progress, Solved, no_progress
from plantsolve.solvers.geometry import rotation as quaternion_rotation
from plantsolve.solvers.rigidity.assembly import (FINGER_REACH, FINGER_TILT, HALF_PITCH, OFFSET_REACH, SNAP,
                                                  STUD_LENGTH_IN, Assembly, JointSpec, natural_order)
from plantsolve.solvers.rigidity.catalogue import PartShape, lookup, normalise_number, recorded_part
from plantsolve.solvers.rigidity.collisions import Solid
from plantsolve.solvers.rigidity.contacts import CONTACT_GAP
from plantsolve.solvers.rigidity.docking import dock
from plantsolve.solvers.rigidity.lone import lone_motions
from plantsolve.solvers.rigidity.mobility import NEAR_CUT
from plantsolve.solvers.rigidity.misses import REACH, UNKNOWN_REACH, Misses, unknown_near
from plantsolve.solvers.rigidity.pieces import (APART_GAP, APART_MISS, LINED_UP, LOOSE_CLEARANCE, MINIFIGURE, TOUCH_GAP,
                                                clearance, drawn_apart, far_parts, joints_by_part, line_of,
                                                loose_sub_builds, mostly_floating, pieces,
                                                resting_on_smooth_faces, sub_build)
from plantsolve.solvers.rigidity.stickers import is_sticker
from plantsolve.solvers.rigidity.upload import symmetry_planes, symmetry_turns
from plantsolve.solvers.rigidity.verdicts import coverage_verdict, missing_submodels_verdict, one_piece_verdict
from plantsolve.solvers.skipped_input import skipped_lines, source_warnings

MAX_LISTED = 1000
# how report.details.held_pieces recognised each piece (pieces.sub_build, pieces.clearance, pieces.loose_sub_builds)
HELD_BY = {"whole": f"every known part of the named placed sub-model(s) and nothing else, none touching a part of "
                    f"the largest piece (collision boxes at least {TOUCH_GAP:g} LDU apart)",
           "resting": f"every known part of the named placed sub-model(s) and nothing else, touching the largest piece "
                      f"(collision boxes within {TOUCH_GAP:g} LDU) only lying on top of its parts where they have no "
                      f"stud (a tile): nothing there can hold it, as a vehicle standing on a road",
           "minifigure": "minifigure parts only",
           "loose": f"one of the pieces that together are every known part of the named placed sub-model(s) and "
                    f"nothing else, all at least {LOOSE_CLEARANCE:g} LDU clear of the largest piece (collision "
                    f"boxes, or the origins of parts without one): parts loose in a sub-build, or joined to it by "
                    f"parts not in the catalogue"}
LISTED_IN_MESSAGE = 10
# how report.details.separate_builds recognised each piece (pieces.drawn_apart)
APART_BY = (f"standing clear of every part outside it by more than a slip (collision boxes at least {APART_GAP:g} LDU "
            f"apart, parts without one at their origin), no connection point within {APART_MISS:g} LDU of a mate (none "
            f"within {REACH:g} LDU, or the nearest miss further), no part outside the catalogue with its origin within "
            f"{UNKNOWN_REACH:g} LDU")
LISTED_MISSES = 20  # floating parts and separate pieces whose nearest miss the warnings give (details.why)


def _solid(body) -> Solid | None:
    shape = body.shape
    if shape is None:
        return None
    if shape.box is not None:
        q = np.asarray(shape.box.rotation, dtype=float)
        rot = quaternion_rotation(q / math.hypot(*q)).as_matrix()
        return Solid(center=np.asarray(shape.box.center, float), size=np.asarray(shape.box.size, float), rotation=rot)
    return Solid(vertices=np.asarray(shape.mesh.vertices, float), faces=np.asarray(shape.mesh.faces, dtype=np.int32))


def _superbricks(ids: list[str], groups: list[list[int]], rod_pairs: list[tuple[str, str]]) -> list[list[str]]:
    """The exact pass's superbricks (rigid joints) joined further by pairs of parallel pins or axles."""
    root = {ids[b]: ids[g[0]] for g in groups for b in g}

    def find(x):
        while root[x] != x:
            root[x] = root[root[x]]
            x = root[x]
        return x

    for a, b in rod_pairs:
        ra, rb = find(a), find(b)
        if ra != rb:
            root[rb] = ra
    out: dict[str, list[str]] = {}
    for g in groups:
        for b in g:
            out.setdefault(find(ids[b]), []).append(ids[b])
    return list(out.values())


def _pose_key(number: str, rotation: list[float]) -> tuple:
    """The rotation as a key that is one for every turn that takes the part onto itself (a 2 x 4 brick placed
    turned half about its y axis stands where it stood): the least of the rotation times each of its turns."""
    rot = np.reshape(np.asarray(rotation, float), (3, 3))
    return min(tuple(round(float(v) * 1e6) + 0 for v in (rot @ turn).ravel()) for turn in symmetry_turns(number))


def repeated_placements(request: RigidityRequest) -> list[tuple[str, str]]:
    """(first, repeat) id pairs of parts with one part number at one pose (to 0.001 LDU and 1e-6 in the
    rotation, up to the turns that take the part onto itself): a part placed twice, as an editor's
    duplicate-and-forget-to-move leaves it. The first is the id that sorts first in natural order (an upload's
    earlier line), whatever order the parts are listed in."""
    at: dict[tuple, list] = {}  # (number, position) -> its parts in natural order
    for part in sorted(request.parts, key=lambda p: natural_order(p.id)):
        number = lookup(part.part).number if lookup(part.part) else part.part.lower()
        at.setdefault((number, tuple(round(float(v) * 1000) for v in part.position)), []).append(part)
    out = []
    for (number, _), placed in at.items():
        if len(placed) < 2:  # the part's symmetries are sought only where a repeat may be
            continue
        first: dict[tuple, str] = {}
        for part in placed:
            key = _pose_key(number, part.rotation)
            if key in first:
                out.append((first[key], part.id))
            else:
                first[key] = part.id
    return sorted(out, key=lambda pair: natural_order(pair[1]))


COPIES_ANALYSED = 2  # parts of one number analysed at one pose: the part and one repeat (a duplicate, warned)


def set_aside(request: RigidityRequest, repeats: list[tuple[str, str]]) -> tuple[list[UnknownPart], list[str]]:
    """The parts left out of the analysis: the stickers (:mod:`stickers`: drawn flat on a face, no joint, no load),
    and the repeats of a part at one pose beyond the first (``repeats``: :func:`repeated_placements`). A further
    copy at a pose adds no joint, collision or piece that the first repeat does not show already, while every
    copy was matched against every other (1,500 plates 3024 at one spot took two minutes)."""
    defined = {normalise_number(str(n)) for n in (request.source or {}).get("stickers_defined") or ()}
    stickers = [UnknownPart(id=p.id, part=p.part) for p in request.parts
                if lookup(p.part) is None and is_sticker(normalise_number(p.part), defined)]
    copies = Counter()
    extra = []
    for first, repeat in repeats:
        copies[first] += 1
        if copies[first] >= COPIES_ANALYSED:
            extra.append(repeat)
    return stickers, extra


def recorded_parts(source: dict) -> tuple[dict[str, PartShape], list[str]]:
    """The parts the upload reader recognised from the primitives their embedded definitions draw
    (``source.parts_from_primitives``: part number -> catalogue record), and the numbers whose record is unreadable
    (a hand-written request's): those stay unknown."""
    records = source.get("parts_from_primitives")
    shapes, unreadable = {}, []
    for number, record in (records.items() if isinstance(records, dict) else ()):
        try:
            shapes[normalise_number(str(number))] = recorded_part(normalise_number(str(number)), record)
        except ValueError:
            unreadable.append(str(number))
    return shapes, unreadable


def build(request: RigidityRequest, recorded: dict[str, PartShape] | None = None,
          left_out: frozenset[str] | set[str] = frozenset()) -> tuple[Assembly, list[UnknownPart]]:
    """The assembly of a request: bodies and joints, or catalogue parts and the ``recorded`` parts of the file
    (:func:`recorded_parts`), unknown parts set aside, the parts of ids ``left_out`` (:func:`set_aside`) left out."""
    assembly = Assembly()
    unknown = []
    recorded = recorded or {}
    for body in request.bodies:
        assembly.add_body(body.id, _solid(body))
    for joint in request.joints:
        axis = tuple(joint.axis) if joint.axis is not None else None
        assembly.add_joint(JointSpec(joint.id, joint.type, (joint.bodies[0], joint.bodies[1]), tuple(joint.point), axis))
    for part in request.parts:
        if part.id in left_out:
            continue
        known = lookup(part.part) is not None
        shape = None if known else recorded.get(normalise_number(part.part))  # a catalogue part keeps its own
        if not known and shape is None:
            unknown.append(UnknownPart(id=part.id, part=part.part))
            continue
        assembly.add_part(part.id, part.part, part.position, part.rotation, shape=shape)
    assembly.seat_tyres()
    assembly.seat_clips_across_gaps()
    assembly.seat_offset_studs()
    assembly.join_pieces()
    assembly.join_by_contact()
    return assembly, unknown


def unmirrored(request: RigidityRequest) -> tuple[RigidityRequest, Diagnostic | None]:
    """A written request's parts whose rotation mirrors them (negative determinant), as the LDraw reader takes
    them: a part symmetric about a plane of its frame as the rotation its mirror image equals, a handed part as
    given and named in a ``mirrored_parts`` warning (its mirror image is its twin, another part number). An
    upload's parts were so taken by its reader."""
    if (request.source or {}).get("format") == "ldraw":
        return request, None
    parts, handed = [], []
    for i, part in enumerate(request.parts):
        rot = np.reshape(np.asarray(part.rotation, float), (3, 3))
        if np.linalg.det(rot) < 0 and lookup(part.part) is not None:
            planes = symmetry_planes(part.part)
            if planes:
                turned = rot @ max(planes, key=lambda plane: np.trace(rot @ plane))
                part = part.model_copy(update={"rotation": [float(v) + 0.0 for v in turned.ravel()]})
            else:
                handed.append(f"parts[{i}] {part.id!r} ({lookup(part.part).number})")
        parts.append(part)
    warning = Diagnostic(
        code="mirrored_parts", message=f"{len(handed)} part(s) have a rotation of negative determinant, a mirror: "
        f"{', '.join(handed[:LISTED_IN_MESSAGE])}{' and more' if len(handed) > LISTED_IN_MESSAGE else ''}. No part "
        "can be built mirrored — a handed part's mirror image is its twin of the other hand, another part number. "
        "They were analysed as given; give each its twin's number, or a rotation.",
        details={"parts": handed[:MAX_LISTED]}) if handed else None
    return request.model_copy(update={"parts": parts}), warning


def solve(request: RigidityRequest, progress: Progress = no_progress) -> Solved:
    progress(0.0, "building the assembly")
    request, mirrored = unmirrored(request)
    recorded, unreadable = recorded_parts(request.source or {})
    twice = repeated_placements(request)
    stickers, copies = set_aside(request, twice)
    assembly, unknown = build(request, recorded, {p.id for p in stickers} | set(copies))
    warnings: list[Diagnostic] = [mirrored] if mirrored else []
    recognised = [p.id for p in request.parts if p.id in assembly.parts and lookup(p.part) is None] if recorded else []
    if recognised:
        numbers = sorted({assembly.parts[p].number for p in recognised})
        warnings.append(Diagnostic(
            code="parts_from_primitives", message=f"{len(recognised)} part(s) ({', '.join(numbers[:LISTED_IN_MESSAGE])}"
            f"{' and more' if len(numbers) > LISTED_IN_MESSAGE else ''}) are not in the catalogue but defined in the "
            "file: they were recognised from the official primitives and parts their definitions draw (stud.dat, "
            "connhole.dat …), whose snap data places their connections; no collision shape",
            details={"parts": numbers[:100], "ids": recognised[:MAX_LISTED]}))
    if unreadable:
        warnings.append(Diagnostic(code="parts_from_primitives_unreadable", message=f"source.parts_from_primitives "
                                   f"holds no catalogue record for {len(unreadable)} part(s) ("
                                   f"{', '.join(unreadable[:LISTED_IN_MESSAGE])}): they stay unknown",
                                   details={"parts": unreadable[:100]}))
    if unknown:
        tally = Counter(u.part for u in unknown)
        named = ", ".join(f"{number} ({count})" for number, count in sorted(tally.items(), key=lambda t: (-t[1], t[0]))
                          [:LISTED_IN_MESSAGE])
        warnings.append(Diagnostic(code="unknown_parts", message=f"{len(unknown)} of {len(request.parts)} part(s) are "
                                   f"not in the catalogue and were left out of the analysis (not guessed): "
                                   f"{len(tally)} number(s), {named}"
                                   f"{' and more' if len(tally) > LISTED_IN_MESSAGE else ''}"
                                   f"; dof, rigid and pieces are of the other "
                                   f"{len(request.parts) - len(unknown) - len(stickers) - len(copies)}",
                                   details={"parts": sorted(tally)[:100]}))
    source = request.source or {}
    skipped = [s for s in source.get("skipped") or [] if isinstance(s, dict)]
    if skipped:  # lines of the uploaded file that placed nothing: the analysis is of the rest
        count = source.get("skipped_count")
        warnings.append(skipped_lines(skipped, "line", count if isinstance(count, int) else None))
    warnings.extend(source_warnings(source))
    if twice:
        warnings.append(Diagnostic(code="duplicate_parts", message=f"{len(twice)} part(s) repeat another part at "
                                   "the same pose (part number, position and rotation, or a turn that takes the "
                                   "part onto itself): "
                                   + ", ".join(f"{b} repeats {a}" for a, b in twice[:20])
                                   + (f"; {len(copies)} further cop(ies) of a part at a pose where it and one "
                                      "repeat stand already are left out of the analysis (each would add only the "
                                      "same joints and collisions again)" if copies else ""),
                                   details={"pairs": [list(p) for p in twice[:MAX_LISTED]],
                                            "left_out": len(copies), "left_out_ids": copies[:MAX_LISTED]}))
    if stickers:
        tally = Counter(normalise_number(p.part) for p in stickers)
        named = ", ".join(f"{number} ({count})" for number, count in sorted(tally.items(), key=lambda t: (-t[1], t[0]))
                          [:LISTED_IN_MESSAGE])
        warnings.append(Diagnostic(
            code="stickers", message=f"{len(stickers)} sticker(s) ({len(tally)} number(s): {named}"
            f"{' and more' if len(tally) > LISTED_IN_MESSAGE else ''}) are left out of the analysis: a sticker is "
            "drawn flat on another part's face and carries no joint and no load (LDraw category Sticker); they are "
            "not counted as parts the catalogue lacks",
            details={"count": len(stickers), "parts": dict(sorted(tally.items())[:100]),
                     "ids": [p.id for p in stickers][:MAX_LISTED]}))
    progress(0.2, "exact mobility")
    analysis = assembly.analyse(rank_tolerance=request.options.rank_tolerance)
    mob = analysis.mobility
    ids = analysis.ids
    progress(0.6, "collisions")
    tol = request.options.contact_tolerance
    collisions = assembly.collisions(tol)
    if collisions:
        warnings.append(Diagnostic(code="collisions", message=f"{len(collisions)} pair(s) of shapes interpenetrate "
                                   f"deeper than contact_tolerance = {tol}"))
    docking = []
    if request.options.dock is not None:
        progress(0.8, "docking")
        docking = [DockingCandidate(**c) for c in dock(assembly, request.options.dock.part,
                                                       request.options.dock.limit, tol)]
    joints = [JointResult(id=s.id, type=s.type, bodies=list(s.bodies), point=[float(v) for v in s.point],
                          axis=None if s.axis is None else [float(v) for v in s.axis], origin=s.origin,
                          connections=s.connections, moves=m)
              for s, m in zip(analysis.joints, mob.moves)]
    part_ids = list(assembly.parts)
    by_part = joints_by_part(part_ids, ((j.id, j.bodies) for j in joints))
    part_results = [PartJoints(id=p, part=assembly.parts[p].number, joints=by_part[p][0], joined_to=by_part[p][1])
                    for p in part_ids]
    piece_results, held_by = _pieces(part_ids, by_part, assembly, source)
    positions = {p.id: np.asarray(p.position, float) for p in request.parts}
    unknown_ids = [u.id for u in unknown]
    floating = [p.id for p in part_results if not p.joints]
    misses = Misses(assembly) if (floating and len(part_results) > 1) or any(
        pc.sub_build is None for pc in piece_results[1:]) else None
    builds = _separate_builds(piece_results, assembly, positions, unknown_ids, misses, source)
    warnings.extend(_piece_warnings(part_results, piece_results, assembly, positions, unknown_ids, misses, builds))
    warnings.extend(_offset_warnings(assembly))
    warnings.extend(_tilt_warnings(assembly))
    warnings.extend(_contact_warnings(assembly))
    warnings.extend(_far_part_warnings(part_ids, assembly))
    warnings.extend(_spacing_warnings(part_results, assembly))
    n_pieces = mob.details["components"]
    superbricks = _superbricks(ids, mob.superbricks, assembly.rod_pairs())
    special = mob.dof > analysis.generic_dof
    near = mob.details.get("near_cut") or []
    if near:  # before special_position: that one's reading rests on this rank
        warnings.append(Diagnostic(
            code="rank_uncertain", message=f"dof {mob.dof} may be up to {len(near)} too high: the float rank counted "
            f"{len(near)} singular value(s) as zero that lie within a factor {NEAR_CUT:g} below its cut "
            f"(rank_tolerance = {request.options.rank_tolerance:g}; the nearest at {near[0]:.2g} of the cut). Lengths "
            f"spanning too many orders of magnitude (a joint's point far from the others': the model's joints span "
            f"{mob.details['model_size']:.3g} {'ldu' if request.parts else request.units} from their middle) hide a "
            "lever under the cut; lower options.rank_tolerance, or check the numbers",
            details={"near_cut": near, "rank_tolerance": request.options.rank_tolerance}))
    clusters = [[ids[b] for b in c] for c in mob.clusters]
    lone = [LoneMotion(parts=m.parts, numbers=[assembly.parts[p].number for p in m.parts if p in assembly.parts],
                       point=list(m.point), axis=list(m.axis), slides=m.slides, dof=m.dof)
            for m in lone_motions(clusters, analysis.joints)]
    linked = mob.dof - sum(m.dof for m in lone) - 6 * (n_pieces - 1)
    said_lone = _lone_text(lone, linked)
    if special:
        warnings.append(Diagnostic(code="special_position", message=f"the geometry has {mob.dof} degree(s) of freedom "
                                   f"where its joint count gives {analysis.generic_dof} (parallel or collinear axes"
                                   + (f": the joint count takes a part's joints on one line for independent ones); "
                                      f"{said_lone}" if lone else ")"),
                                   details={"lone_dof": sum(m.dof for m in lone), "linked_dof": linked}))
    movable = sum(m for m in mob.moves)
    message = (f"dof {mob.dof} (generic count {analysis.generic_dof}"
               + (f"; {sum(m.dof for m in lone)} of them from {len(lone)} cluster(s) turning alone "
                  f"(result.lone_motions), {linked} linked" if lone else "") + ")"
               + f"; {len(mob.clusters)} rigid cluster(s) of {len(ids)} bodies; {movable} of {len(joints)} joints "
               f"move; {len(collisions)} collision(s)")
    held = [pc for pc in piece_results[1:] if pc.sub_build]
    if held:  # a held sub-build is not a fault, but a reader of the message must not take the set for one piece
        message += (f"; {len(held)} sub-build(s) stand apart as held pieces: "
                    + ", ".join(f"{pc.sub_build} ({len(pc.parts)} parts)" for pc in held[:LISTED_IN_MESSAGE]))
    if builds:  # nor a set of several builds for one build in pieces
        message += (f"; the drawing places {len(builds)} piece(s) apart as separate builds: "
                    + ", ".join(f"{b['first']} ({b['parts']} parts)" for b in builds[:LISTED_IN_MESSAGE]))
    source = request.source or {}
    not_read, past_limit = (source.get(key) for key in ("placements_not_read", "parts_past_limit"))
    coverage = coverage_verdict(len(part_ids), [u.part.lower() for u in unknown],
                                np.array([positions[u.id] for u in unknown], dtype=float).reshape(-1, 3),
                                *(n if type(n) is int and n > 0 and request.parts else 0 for n in (not_read, past_limit)))
    # a model of parts is one build unless its drawing says otherwise (bodies and joints: the joints are the user's)
    apart = one_piece_verdict(piece_results) if request.parts else None
    missing = missing_submodels_verdict(source.get("missing_submodels") or {}, source.get("missing_submodels_count"))
    # the verdicts first, the gravest first
    warnings = [v for v in (missing, coverage, apart) if v is not None] + warnings
    report = Report(status="warning" if warnings else "ok", message=message, warnings=warnings, details={
        "bodies": len(ids), "joints": len(joints), "constraint_rows": mob.rows, "blocks": mob.blocks,
        "largest_block": mob.largest_block, "connected_pieces": n_pieces,
        "held_pieces": [{"parts": len(pc.parts), "sub_build": pc.sub_build, "recognised_by": held_by[k]}
                        for k, pc in enumerate(piece_results) if k in held_by],
        "separate_builds": builds[:MAX_LISTED], "separate_builds_rule": APART_BY,
        "rank_method": mob.rank_method,
        "source": request.source or {}})
    progress(1.0, "done")
    return Solved(RigidityResult(
        length_unit="ldu" if request.parts else request.units, dof=mob.dof, generic_dof=analysis.generic_dof,
        special_position=special,
        rigid=None if missing or coverage or apart else bool(ids) and n_pieces == 1 and mob.dof == 0,
        clusters=clusters, lone_motions=lone, linked_dof=linked, superbricks=superbricks,
        joints=joints, redundant_constraints=mob.redundant_constraints,
        collisions=[Collision(bodies=[a, b], depth=d) for a, b, d in collisions[:MAX_LISTED]],
        docking=docking, unknown_parts=unknown, parts=part_results, pieces=piece_results, rank_method=mob.rank_method,
        report=report))


def _lone_text(lone: list[LoneMotion], linked: int) -> str:
    """The lone motions in words (:mod:`lone`): how many dof they make, what turns, grouped by part numbers (ids for
    bodies), the first of each group named, and what is left."""
    groups: dict[str, list[LoneMotion]] = {}
    for m in lone:
        kinds = Counter(m.numbers)
        key = " + ".join(f"{n} x {k}" if n > 1 else k for k, n in kinds.items()) or "body"
        groups.setdefault(key if len(kinds) < 2 and sum(kinds.values()) < 2 else f"({key})", []).append(m)
    ranked = sorted(groups.items(), key=lambda g: (-len(g[1]), g[0]))
    named = ", ".join(f"{len(ms)} x {key} (first {ms[0].parts[0]})" for key, ms in ranked[:LISTED_IN_MESSAGE])
    sliding = sum(m.slides for m in lone)
    return (f"{sum(m.dof for m in lone)} of them are {len(lone)} rigid cluster(s) turning alone about one line "
            f"through all their joints, moving no other part (a pin or an axle in round holes, a wheel or a gear on "
            f"its axle, a door on its hinge): {named}{' and more' if len(ranked) > LISTED_IN_MESSAGE else ''}"
            + (f"; {sliding} of them slide along that line too (cylindrical joints only)" if sliding else "")
            + f"; {linked} move several clusters together (result.lone_motions lists each, result.linked_dof counts "
            "the rest)")


def _pieces(part_ids: list[str], by_part: dict, assembly: Assembly,
            source: dict) -> tuple[list[Piece], dict[int, str]]:
    """The connected pieces of the known parts, largest first, the others named when they are sub-builds; and for
    each held piece (by index) the rule that recognised it (HELD_BY)."""
    placements = source.get("submodel_placements") if isinstance(source.get("submodel_placements"), dict) else {}
    names = {p: assembly.parts[p].shape.name for p in part_ids}
    groups = pieces(part_ids, {p: joined for p, (_, joined) in by_part.items()})
    if not groups:
        return [], {}
    lows, highs, lows_or_points, highs_or_points = _boxes(part_ids, assembly)
    found: list[str | None] = [None]
    held_by: dict[int, str] = {}
    apart: list[int] = []  # pieces standing apart from the largest that are no sub-build each
    for k, g in enumerate(groups[1:], start=1):
        name = sub_build(g, part_ids, placements, names)
        if name is not None and name != MINIFIGURE and clearance(g, groups[0], lows, highs) < TOUCH_GAP:
            if resting_on_smooth_faces(g, groups[0], lows, highs, lambda p: _studs_up(assembly, p)):
                held_by[k] = "resting"  # nothing where it lies could hold it: a car on a road of tiles
            else:
                name = None  # whole sub-models lying against the build: a part of it whose joint was not found
        elif name is not None:
            held_by[k] = "minifigure" if name == MINIFIGURE else "whole"
        if name in (None, MINIFIGURE) and all("/" in p for p in g) and clearance(
                g, groups[0], lows_or_points, highs_or_points) >= LOOSE_CLEARANCE:
            # (a part of the main model lies in no placement: it cannot be of a sub-build); a piece of minifigure
            # parts only too, which may be the rest of a vehicle standing apart (3181-1's seat, loose on its car)
            apart.append(k)
        found.append(name)
    for k, name in zip(apart, loose_sub_builds([groups[k] for k in apart], part_ids, placements)):
        if name is not None:
            found[k], held_by[k] = name, "loose"
    return [Piece(parts=g, sub_build=name) for g, name in zip(groups, found)], {k: HELD_BY[v] for k, v in
                                                                               held_by.items()}


def _studs_up(assembly: Assembly, id: str) -> np.ndarray:
    """The points of part ``id``'s studs that point up (LDraw's -y, within 1 degree), an (n, 3) array."""
    placed = assembly.parts[id]
    rows = [placed.points[k] for k, c in enumerate(placed.shape.connectors)
            if c.type == "stud" and float(placed.directions[k][1]) < -0.9998]
    return np.array(rows, dtype=float).reshape(-1, 3)


def _boxes(part_ids: list[str], assembly: Assembly) -> tuple[dict, dict, dict, dict]:
    """The parts' world-aligned collision boxes (lower, upper corners by id), and the same with each part that has no
    collision shape (a minifigure's, a hose segment) as a point at its origin, as pieces that must stand clear count
    it."""
    ids, _, lower, upper = assembly.solid_boxes()
    finite = np.isfinite(lower).all(axis=1)
    lows = {b: lo for b, lo, ok in zip(ids, lower, finite) if ok}
    highs = {b: hi for b, hi, ok in zip(ids, upper, finite) if ok}
    points = {p: assembly.parts[p].position for p in part_ids if p not in lows}
    return lows, highs, {**lows, **points}, {**highs, **points}


def _separate_builds(found: list[Piece], assembly: Assembly, positions: dict, unknown: list[str],
                     misses: Misses | None, source: dict) -> list[dict]:
    """Mark the pieces that the drawing places apart (:func:`pieces.drawn_apart`: no held sub-build, standing APART_GAP
    clear of everything outside them, no mate within APART_MISS, no unknown part beside them) and describe each for
    report.details.separate_builds: its first part, part count, the top-level placements it lies in (the sub-models
    the main model places, by file name, or "main model" for its own lines) and its nearest miss (LDU, None: no mate
    within misses.REACH)."""
    part_count = sum(len(pc.parts) for pc in found)
    if misses is None or mostly_floating(sum(len(pc.parts) == 1 for pc in found), part_count):
        return []  # where most parts meet nothing (a parts list, or positions in another unit) no build is told apart
    part_ids = [p for pc in found for p in pc.parts]
    _, _, lows, highs = _boxes(part_ids, assembly)
    placements = source.get("submodel_placements") if isinstance(source.get("submodel_placements"), dict) else {}
    out = []
    for pc in found[1:]:
        if pc.sub_build is not None:
            continue
        members = set(pc.parts)
        rest = [p for p in part_ids if p not in members]
        near = misses.nearest(pc.parts)
        gap = near["gap_ldu"] if near is not None else None
        lined_up = near is not None and near["sideways_ldu"] <= LINED_UP
        if not drawn_apart(clearance(pc.parts, rest, lows, highs), gap,
                           bool(unknown_near(pc.parts, positions, unknown)), lined_up):
            continue
        pc.drawn_apart = True
        tops = list(dict.fromkeys(p.split("/")[0] + "/" if "/" in p else "" for p in pc.parts))
        out.append({"first": pc.parts[0], "parts": len(pc.parts),
                    "numbers": sorted({assembly.parts[p].number for p in pc.parts})[:LISTED_IN_MESSAGE],
                    "placements": [placements.get(t, t.rstrip("/")) if t else "main model" for t in tops],
                    "nearest_ldu": gap})
    return out


def _named(ids, assembly: Assembly) -> str:
    shown = [f"{p} ({assembly.parts[p].number})" for p in ids[:LISTED_IN_MESSAGE]]
    return ", ".join(shown) + (f" and {len(ids) - len(shown)} more" if len(ids) > len(shown) else "")


def _piece_warnings(parts: list[PartJoints], found: list[Piece], assembly: Assembly, positions: dict,
                    unknown: list[str], misses: Misses | None, builds: list[dict]) -> list[Diagnostic]:
    out = []
    floating = [p.id for p in parts if not p.joints]
    apart = [pc for pc in found[1:] if pc.sub_build is None and not pc.drawn_apart and len(pc.parts) > 1]
    if floating and len(parts) > 1:
        why = [_why([p], misses, positions, unknown) for p in floating[:LISTED_MISSES]]
        out.append(Diagnostic(code="floating_parts", message=f"{len(floating)} of {len(parts)} known part(s) are "
                              f"joined to nothing (no connection of the catalogue meets them): "
                              f"{_named(floating, assembly)}; {_why_text(floating, why, assembly)}",
                              details={"parts": [{"id": p, "part": assembly.parts[p].number, "line": line_of(p)}
                                                 for p in floating[:MAX_LISTED]],
                                       "count": len(floating), "known_parts": len(parts), "why": why}))
    if apart:
        why = [_why(pc.parts, misses, positions, unknown) for pc in apart[:LISTED_MISSES]]
        out.append(Diagnostic(code="separate_pieces", message=f"besides the largest piece ({len(found[0].parts)} "
                              f"parts), {len(apart)} piece(s) of several parts are joined to nothing else and are "
                              f"no sub-build (a sub-model or a minifigure): "
                              + "; ".join(_named(pc.parts, assembly) for pc in apart[:LISTED_IN_MESSAGE])
                              + "; " + _why_text([pc.parts[0] for pc in apart], why, assembly),
                              details={"pieces": [pc.parts[:MAX_LISTED] for pc in apart[:MAX_LISTED]], "why": why}))
    if builds:
        out.append(Diagnostic(code="separate_builds", message=f"the drawing places {len(builds)} piece(s) apart from "
                              f"the rest of the model, so it is {len(builds) + 1} or more builds as drawn (a second "
                              "vehicle, an animal, an accessory or spare parts laid aside, or a part fallen off; no "
                              f"joint can join them as drawn): {APART_BY}: "
                              + "; ".join(_build_text(b) for b in builds[:LISTED_IN_MESSAGE]),
                              details={"builds": builds[:MAX_LISTED], "rule": APART_BY}))
    return out


def _build_text(build: dict) -> str:
    """A separate build in words: its first part, its part count and first numbers, where it lies, its nearest miss."""
    numbers = ", ".join(build["numbers"][:3]) + (" …" if len(build["numbers"]) > 3 else "")
    near = (f"nearest mate {build['nearest_ldu']:g} LDU off" if build["nearest_ldu"] is not None
            else f"no mate within {REACH:g} LDU")
    return f"{build['first']} ({build['parts']} part(s): {numbers}; in {', '.join(build['placements'][:3])}; {near})"


def _why(piece: list[str], misses: Misses, positions: dict, unknown: list[str]) -> dict:
    """What the drawing shows between a piece (or a part) and the rest: its nearest miss
    (:meth:`misses.Misses.nearest`, None: no mate within misses.REACH) and the parts not in the catalogue beside it."""
    return {"nearest": misses.nearest(piece), "unknown_near": unknown_near(piece, positions, unknown)[:LISTED_IN_MESSAGE]}


def _why_text(first: list[str], why: list[dict], assembly: Assembly) -> str:
    """The nearest misses in words: each is further off than the OFFSET_REACH a slip is joined within, so the drawing
    places no joint there, unless a part the catalogue does not know holds it."""
    said = []
    for pid, w in zip(first[:LISTED_IN_MESSAGE], why):
        near = w["nearest"]
        text = (f"{pid}: no mate within {REACH:g} LDU" if near is None else
                f"{near['part']} ({near['number']}) {near['type']} {near['gap_ldu']:g} LDU from {near['other']} "
                f"({near['other_number']}) {near['other_type']}")
        if w["unknown_near"]:
            text += " beside part(s) not in the catalogue: " + ", ".join(w["unknown_near"][:3])
        said.append(text)
    return (f"no joint in the drawing within the {OFFSET_REACH - SNAP:g} LDU a slip is joined at, nearest misses: "
            + "; ".join(said))


def _offset_warnings(assembly: Assembly) -> list[Diagnostic]:
    """``offset_joints``: the part pairs joined although their connection points miss each other by more than
    rounding (:meth:`Assembly.join_pieces`), each with its offset."""
    offsets = assembly.offsets()
    if not offsets:
        return []
    worst = max(offsets.values())
    listed = sorted(offsets.items(), key=lambda item: -item[1])
    return [Diagnostic(code="offset_joints", message=f"{len(offsets)} pair(s) of parts are joined although their "
                       f"connection points miss each other by more than rounding ({SNAP:g} LDU), up to {worst:.3g} LDU "
                       f"(at most {OFFSET_REACH:g} is taken for a part drawn off its mate, {FINGER_REACH:g} between "
                       f"the axes of interleaved hinge fingers, {STUD_LENGTH_IN:g} for an anti-stud drawn on a stud's "
                       f"tip, under {HALF_PITCH:g} for a part's studs all drawn one way beside their anti-studs in "
                       "one plane; 1 LDU = 0.4 mm): "
                       + ", ".join(f"{a} ({assembly.parts[a].number}) and {b} ({assembly.parts[b].number}) "
                                   f"{gap:.3g} LDU" for (a, b), gap in listed[:LISTED_IN_MESSAGE]),
                       details={"pairs": [{"parts": [a, b], "numbers": [assembly.parts[a].number,
                                                                         assembly.parts[b].number],
                                           "offset_ldu": round(gap, 3)} for (a, b), gap in listed[:MAX_LISTED]],
                                "reach_ldu": OFFSET_REACH, "finger_reach_ldu": FINGER_REACH,
                                "stud_tip_ldu": STUD_LENGTH_IN, "shifted_rows_ldu": HALF_PITCH})]


def _tilt_warnings(assembly: Assembly) -> list[Diagnostic]:
    """``tilted_joints``: the part pairs joined by hinge fingers that share their middle with their axes drawn turned
    off each other (:meth:`Assembly.join_pieces`), each with the angle."""
    tilts = assembly.tilts()
    if not tilts:
        return []
    listed = sorted(tilts.items(), key=lambda item: (-item[1], natural_order(item[0][0])))
    return [Diagnostic(code="tilted_joints", message=f"{len(tilts)} pair(s) of parts are joined by hinge fingers whose "
                       f"axes are drawn up to {listed[0][1]:.3g} degrees off each other, their middles on one point (a "
                       "part swung about another axis than its hinge's; joined as a hinge about the turned part's "
                       f"axis, at most {math.degrees(math.acos(FINGER_TILT)):g} degrees): "
                       + ", ".join(f"{a} ({assembly.parts[a].number}) and {b} ({assembly.parts[b].number}) "
                                   f"{angle:.3g} degrees" for (a, b), angle in listed[:LISTED_IN_MESSAGE]),
                       details={"pairs": [{"parts": [a, b], "numbers": [assembly.parts[a].number,
                                                                         assembly.parts[b].number],
                                           "angle_degrees": round(angle, 2)} for (a, b), angle in listed[:MAX_LISTED]],
                                "max_angle_degrees": round(math.degrees(math.acos(FINGER_TILT)), 6)})]


def _contact_warnings(assembly: Assembly) -> list[Diagnostic]:
    """``contact_joints``: the part pairs joined by face contact where no snap meets, a part wedged in a gap of another
    piece (:meth:`Assembly.join_by_contact`), each with the contact's normal."""
    contacts = assembly.contacts()
    if not contacts:
        return []
    listed = sorted(contacts.items(), key=lambda item: (natural_order(item[0][0]), natural_order(item[0][1])))
    return [Diagnostic(code="contact_joints", message=f"{len(contacts)} pair(s) of parts are joined by contact only: "
                       "a part wedged in a gap of another piece, its collision box touching two of that piece's face "
                       f"on face on opposite sides as drawn (within {CONTACT_GAP:g} LDU), where no snap of the "
                       "catalogue meets and no face carries studs or anti-studs across the contact (held by "
                       "friction). A contact joint is planar: it holds the "
                       "translation along the normal and the two tilts, and leaves the slide in the faces' plane and "
                       "the turn about the normal (3 degrees of freedom; a stud joint leaves 1, two studs 0): "
                       + ", ".join(f"{a} ({assembly.parts[a].number}) and {b} ({assembly.parts[b].number})"
                                   for (a, b), _ in listed[:LISTED_IN_MESSAGE]),
                       details={"pairs": [{"parts": [a, b], "numbers": [assembly.parts[a].number,
                                                                         assembly.parts[b].number],
                                           "normal": [float(v) for v in normal]} for (a, b), normal in
                                          listed[:MAX_LISTED]],
                                "gap_ldu": CONTACT_GAP})]


# Units a model's positions may have been written in instead of LDU, with the factor to LDU: a model whose parts
# mostly float but join once its positions are scaled by one of these was written in that unit.
OTHER_UNITS = {"mm": 2.5, "studs": 20.0, "cm": 25.0}
SPACING_CHECK_PARTS = 2000  # the check rebuilds the model once per unit: only models up to this size


def _spacing_warnings(parts: list[PartJoints], assembly: Assembly) -> list[Diagnostic]:
    """``implausible_part_spacing`` when most known parts are joined to nothing and the positions scaled from
    another unit to LDU join most of them."""
    floating = sum(1 for p in parts if not p.joints)
    if not mostly_floating(floating, len(parts)) or len(parts) > SPACING_CHECK_PARTS:
        return []
    for unit_name, factor in OTHER_UNITS.items():
        trial = Assembly()
        for p in parts:
            placed = assembly.parts[p.id]
            trial.add_part(p.id, placed.number, placed.position * factor, placed.rotation)
        joined = {b for j in trial.all_joints() for b in j.bodies}
        if (len(parts) - len(joined)) * 2 < floating:
            return [Diagnostic(code="implausible_part_spacing", message=f"part spacing: {floating} of {len(parts)} "
                               f"parts are joined to nothing at the positions as written, but only "
                               f"{len(parts) - len(joined)} once the positions are multiplied by {factor:g} — "
                               f"positions written in {unit_name} read as LDU (1 LDU = 0.4 mm, a stud 20 LDU, a "
                               "brick 24 high)?",
                               details={"unit": unit_name, "factor_to_ldu": factor, "floating_as_written": floating,
                                        "floating_scaled": len(parts) - len(joined)})]
    return []


def _far_part_warnings(part_ids: list[str], assembly: Assembly) -> list[Diagnostic]:
    positions = np.array([assembly.parts[p].position for p in part_ids], dtype=float).reshape(-1, 3)
    far = far_parts(part_ids, positions)
    if not far:
        return []
    described = "; ".join(f"{p} ({assembly.parts[p].number}" + (f", line {line_of(p)}" if line_of(p) else "")
                          + f") at {d:.3g} LDU" for p, d, _ in far[:LISTED_IN_MESSAGE])
    return [Diagnostic(code="implausible_part_position", message=f"part position: {len(far)} part(s) lie implausibly "
                       f"far from the middle of the model (plausible: within {far[0][2]:.3g} LDU; 1 LDU = 0.4 mm): "
                       f"{described} — digits typed twice, or a position in another unit (mm, or a CAD export's "
                       "units) read as LDU?",
                       details={"parts": [{"id": p, "part": assembly.parts[p].number, "line": line_of(p),
                                           "distance_ldu": d} for p, d, _ in far[:MAX_LISTED]],
                                "bound_ldu": far[0][2]})]
