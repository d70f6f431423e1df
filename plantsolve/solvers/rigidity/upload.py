"""Files a model comes in: LDraw ``.ldr`` / ``.mpd`` (type-1 part lines) or a JSON request.

LDraw as LDCad, LeoCAD, MLCad and BrickLink Studio write it: a line's first token is its type.
Type 1 is ``1 <colour> x y z a b c d e f g h i <file>`` (position in LDU, the rotation row-major,
the file name possibly with spaces and in any case, with or without ``.dat``); it places a part,
or a sub-model of the same ``.mpd``, which is expanded with its placement composed (sub-models of
sub-models too; a sub-model that includes itself is refused at that line). Type 0 lines are
comments and meta commands (``0 FILE`` and ``0 NOFILE`` delimit the sub-files of an ``.mpd``, in any order: the
main model is the first that no other places; a name given to two sections of different contents is refused, and a
sub-model the main model never places is warned about (``unplaced_submodels``);
``0 STEP``, ``0 !LDCAD …``, ``0 !LEOCAD …``, ``0 MLCAD …``, ``0 ROTSTEP``, ``0 BFC`` and the rest
are ignored), types 2–5 are drawn geometry (lines, triangles, quads) and ignored, colours are
ignored. Packed models (three.js' packer, web viewers; Studio and LDCad embedding unofficial parts) hold
the main model's lines before the first ``0 FILE`` and the parts' own definitions as ``0 FILE`` sections
(``parts/3001.dat``, ``p/…``, ``parts/s/…``): a type-1 line's name finds its section whatever the case,
``\\`` or ``/``, and with or without the library folder. A section headed ``!LDRAW_ORG Part`` or
``Shortcut`` (``Unofficial_`` or not), or without a header but named for a catalogue part, is that part
and is placed, not expanded; subparts and primitives are drawn geometry. Item by item: a type-1 line
that cannot be read (a matrix that scales or shears, a position beyond 1e12 LDU) is skipped and listed in the
report with its line and reason, a rotation printed with few digits (``0.985 -0.17 0``) is read as the
nearest rotation (``source.rotations_rounded`` counts them; a sub-model's placement up to a few per cent
off, typed by hand, too, with a ``rotation_rounded`` warning naming its lines), a primitive placed in a model
is drawn geometry however it is scaled, and a line placing a ``.ldr`` or ``.mpd`` the file
does not hold (a cut ``.mpd``, an ``.ldr`` without its sub-model files) is skipped naming it; parts not in the
catalogue are kept and reported as unknown by the solver (never guessed), except a part the file defines
itself (an embedded unofficial part) whose definition draws official primitives, subparts or parts with snap data
(``stud.dat``, ``connhole.dat``, ``s/3001s01.dat``): its snaps are theirs, placed by the definition's matrices
(:mod:`embedded`), handed to the solver in ``source.parts_from_primitives`` (part number -> catalogue record),
and the solver says which parts it recognised so;
the file is refused (422 naming the file) only when it places no part at all, or when it is one part's own
drawing (headed ``0 !LDRAW_ORG Part``, placing no catalogue part), not a model.
Part ids are ``L<line>`` in the main model and ``<parent id>/L<line>`` inside sub-models;
``source.submodel_placements`` maps each placed sub-model's id prefix (``L12/``) to its file name.
"""

from __future__ import annotations

import difflib
import functools
import itertools
import re

import numpy as np

from plantsolve.schemas import alignment, dedup, flowmeter, perfmap, polyhedra, tube
from plantsolve.schemas.common import MAX_COORDINATE, Diagnostic
from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.solvers.base import StoredInput, decode_text, json_object, reject
from plantsolve.solvers.rigidity.catalogue import lookup, normalise_number
from plantsolve.solvers.rigidity.embedded import Resolver, official
from plantsolve.solvers.rigidity.stickers import STICKER, category
from plantsolve.solvers.skipped_input import ends_mid_line, truncated_file
from plantsolve.solvers.upload_form import FormRules, request_of_file

UPLOAD_EXTENSIONS = (".ldr", ".mpd", ".json")
MAX_DEPTH = 32
# LDraw has one length unit; results of parts keep it (length_unit 'ldu'): no conversion, said where it comes from
LDRAW_UNITS = {"file_unit": "ldu", "result_unit": "ldu", "factor": 1.0,
               "from": "the LDraw format: positions are LDraw units (1 LDU = 0.4 mm, a stud pitch 20, a brick 24 high)"}
MAX_SKIPPED_LISTED = 200
MAX_PLACEMENTS_LISTED = 2000  # sub-model placements named in source (the solver tells sub-builds by them)
MAX_PARTS = 20_000
NOT_READ, PAST_LIMIT = "not_read", "past_limit"  # why a skipped line's parts are missing: its placement, MAX_PARTS
# Rows of a placement's matrix off orthonormal by up to this are a rotation printed with few digits, read as the
# nearest rotation; further off, the line scales or shears its part and is skipped.
ROUNDED_ROTATION = 1e-2
# A sub-model's placement whose rows are off by up to this (a few per cent: rotations typed by hand, 0.99 -0.194
# 0) is read as the nearest rotation too, with a warning naming the lines: skipping it would drop every part
# of the sub-model (OMR 10174 lost 291 of 1065 parts so), and scaling a sub-model is no way to build one.
HAND_TYPED_ROTATION = 6e-2
PRELUDE = "<main>"  # the text before the first '0 FILE'
FOLDERS = ("parts/", "p/", "models/")  # where LDraw's search path looks; packers write the folder into the name
GEOMETRY_FOLDERS = ("p/", "s/", "parts/s/", "48/", "8/")  # primitives and subparts: drawn geometry, not parts
PART_TYPES = {"part", "shortcut"}  # !LDRAW_ORG types (without 'Unofficial_') of a part's own definition
GEOMETRY_TYPES = {"subpart", "primitive", "8_primitive", "48_primitive", "helper"}


def _key(name: str) -> str:
    """A sub-file's name as the lookup key: case and ``\\`` or ``/`` separators do not matter."""
    return name.strip().replace("\\", "/").lower()


def _files(text: str) -> tuple[str, dict[str, list[tuple[int, str]]], list[int]]:
    """The main model's key, every sub-file's numbered lines (one unnamed file for a plain .ldr) and the type-1
    lines after a ``0 NOFILE`` that no ``0 FILE`` section holds (LDraw readers ignore them).

    The main model is the text before the first ``0 FILE`` when that text places anything (a packed
    model, as three.js' packer writes it, has no ``0 FILE`` line of its own), else the first ``0 FILE`` that no
    other sub-model places (:func:`_main_model`). A name given to two ``0 FILE`` sections of different contents
    is refused: which one a placement means is unknown."""
    files: dict[str, list[tuple[int, str]]] = {}
    headers: dict[str, int] = {}  # each sub-file's '0 FILE' line
    order: list[str] = []
    current = PRELUDE
    outside: list[int] = []  # type-1 lines after a '0 NOFILE', in no section: no model holds them
    repeated: tuple[str, int] | None = None  # a name met again (its lines collected apart, then compared)
    again: list[tuple[int, str]] = []

    def close_repeat() -> None:
        if repeated is not None and _content(again) != _content(files[repeated[0]]):
            name, line = repeated
            raise reject(f"the file defines sub-file {name!r} twice with different contents ('0 FILE' at lines "
                         f"{headers[name]} and {line}): which one its placements mean is unknown; rename one of them")

    for number, raw in enumerate(text.splitlines(), 1):
        tokens = raw.split()
        if len(tokens) >= 2 and tokens[0] == "0" and tokens[1].upper() in ("FILE", "NOFILE"):
            close_repeat()
            repeated, again = None, []
            if tokens[1].upper() == "NOFILE":
                current = ""  # text between files belongs to no model
                continue
            # a section without a name is read too (it can be the main model), under a name no line can place
            current = _key(raw.strip()[1:].strip()[4:]) or f"<unnamed at line {number}>"
            if current in headers:
                repeated = (current, number)
            else:
                headers[current] = number
                order.append(current)
                files[current] = []
            continue
        if repeated is not None:
            again.append((number, raw))
        elif current:
            files.setdefault(current, []).append((number, raw))
        elif tokens[:1] == ["1"]:
            outside.append(number)
    close_repeat()
    prelude_places = any(raw.split()[:1] == ["1"] for _, raw in files.get(PRELUDE, ()))
    if prelude_places or not order:
        return PRELUDE, files, outside
    return _main_model(order, files), files, outside


def _content(lines: list[tuple[int, str]]) -> list[str]:
    """A section's lines as they read (numbers, blank lines and trailing spaces aside)."""
    return [raw.strip() for _, raw in lines if raw.strip()]


def _main_model(order: list[str], files: dict[str, list[tuple[int, str]]]) -> str:
    """The first ``0 FILE`` section, as the MPD format says, unless another sub-model places it: then it is a
    sub-model written first (sections shuffled, by hand or by a tool that sorts them), and the main model is the
    first sub-model that nothing places. So the answer does not depend on the order of the sections."""
    placed: set[str] = set()
    for name in order:
        for _, raw in files[name]:
            tokens = raw.split()
            if tokens[:1] == ["1"] and len(tokens) >= 15:
                sub = _resolve(raw.split(None, 14)[14], files)
                if sub is not None and sub != name:
                    placed.add(sub)
    if order[0] not in placed:
        return order[0]
    return next((name for name in order if name not in placed), order[0])


def _placed_submodels(main: str, files: dict, roles: dict) -> set[str]:
    """The sub-models the main model places, directly or through its sub-models, whatever became of the placing
    line (a placement skipped for its matrix or its depth still places the sub-model: the file is not at fault)."""
    placed, todo = {main}, [main]
    while todo:
        for _, raw in files.get(todo.pop(), []):
            fields = raw.split(None, 14)
            if len(fields) < 15 or fields[0] != "1":
                continue
            sub = _resolve(fields[14].strip(), files)
            if sub is not None and sub not in placed and roles.get(sub, "model") == "model":
                placed.add(sub)
                todo.append(sub)
    return placed


def _resolve(name: str, files: dict) -> str | None:
    """The embedded sub-file a type-1 line's file name means: as written, or with its library folder
    added or dropped (``parts/3001.dat`` for ``3001.dat``, ``parts/s/x.dat`` for ``s/x.dat``)."""
    key = _key(name)
    if key in files:
        return key
    for folder in FOLDERS:
        if key.startswith(folder) and key[len(folder):] in files:
            return key[len(folder):]
    for folder in FOLDERS:
        if folder + key in files:
            return folder + key
    return None


def _named_alike(name: str, files: dict) -> str | None:
    """The sub-file whose name is nearest a name the file places but does not hold: the same but for its
    extension (``.dat`` for ``.ldr``) or a typing slip; None when none is near."""
    stem = _key(name).rsplit(".", 1)[0]
    for key in files:
        if key != PRELUDE and key.rsplit(".", 1)[0] == stem:
            return key
    near = difflib.get_close_matches(_key(name), [key for key in files if key != PRELUDE], n=1, cutoff=0.85)
    return near[0] if near else None


def _section_type(lines: list[tuple[int, str]]) -> str | None:
    """The ``!LDRAW_ORG`` type of a sub-file in lower case without ``unofficial_`` ('part', 'subpart',
    'model', …), or None without that header."""
    for _, raw in lines:
        tokens = raw.split()
        if len(tokens) >= 3 and tokens[0] == "0" and tokens[1].upper().lstrip("!") == "LDRAW_ORG":
            kind = tokens[2].lower()
            return kind[len("unofficial_"):] if kind.startswith("unofficial_") else kind
    return None


def _draws_without_parts(lines: list[tuple[int, str]]) -> bool:
    """Drawn geometry (types 2–5, subparts and primitives, ``stud.dat`` among them) and no catalogue part placed:
    how a part's own definition looks."""
    draws = False
    for _, raw in lines:
        tokens = raw.split()
        if tokens[:1] in (["2"], ["3"], ["4"], ["5"]):
            draws = True
        elif tokens[:1] == ["1"] and len(tokens) >= 15 and _key(raw.split(None, 14)[14]).startswith(GEOMETRY_FOLDERS):
            draws = True  # a subpart or primitive drawn
        elif tokens[:1] == ["1"] and len(tokens) >= 15 and official(raw.split(None, 14)[14]) is not None \
                and lookup(raw.split(None, 14)[14]) is None:
            draws = True  # a primitive with snap data (stud.dat)
        elif tokens[:1] == ["1"] and len(tokens) >= 15 and lookup(raw.split(None, 14)[14]) is not None:
            return False
    return draws


def _classify(files: dict[str, list[tuple[int, str]]], main: str) -> dict[str, str]:
    """Each sub-file as 'part' (a part's definition: the part itself is placed), 'geometry' (a subpart
    or primitive: drawn, not a part) or 'model' (a sub-model, expanded). A part header decides; without
    one, a catalogue part number is that part, and a ``.dat`` file of drawn geometry that places no
    catalogue part is an (unknown) part's definition."""
    out = {}
    for name, lines in files.items():
        if name == main:
            out[name] = "model"
            continue
        kind = _section_type(lines)
        if kind in PART_TYPES and not (lookup(name) is None and len(_catalogue_parts(lines)) >= 2):
            out[name] = "part"
        elif kind in GEOMETRY_TYPES:
            out[name] = "geometry"
        elif kind is None and lookup(name) is not None:
            out[name] = "part"
        elif kind is None and name.endswith(".dat") and _draws_without_parts(lines):
            out[name] = "part"
        else:
            out[name] = "model"
    return out


def _catalogue_parts(lines: list[tuple[int, str]]) -> list[str]:
    """The catalogue parts a sub-file's type-1 lines place (their numbers, in line order)."""
    return [normalise_number(name) for _, raw in lines if raw.split()[:1] == ["1"] and len(raw.split()) >= 15
            and lookup(name := raw.split(None, 14)[14].strip()) is not None]


def _headed_parts_expanded(files: dict[str, list[tuple[int, str]]], roles: dict[str, str], main: str) -> Diagnostic | None:
    """A warning naming the sub-files headed ``!LDRAW_ORG Part`` or ``Shortcut`` that were expanded as sub-models: a
    header copied from a part file onto a sub-model, or an unofficial shortcut of several parts (a hinge's two halves).
    Read as one part, the parts it places would be glued into one rigid body — a hinge among them frozen, the degrees
    of freedom undercounted."""
    headed = [name for name, role in roles.items()
              if role == "model" and name != main and _section_type(files[name]) in PART_TYPES]
    if not headed:
        return None
    placed = {name: _catalogue_parts(files[name]) for name in headed}
    named = ", ".join(f"{name!r} ({len(placed[name])} parts: {', '.join(placed[name][:4])}"
                      f"{' …' if len(placed[name]) > 4 else ''})" for name in headed[:5])
    return Diagnostic(
        code="part_header_on_submodel", message=f"{len(headed)} sub-file(s) headed as a part ('0 !LDRAW_ORG Part' or "
        f"'Shortcut') place several catalogue parts: {named}{' and more' if len(headed) > 5 else ''}. Each was read as a sub-model, its parts "
        "analysed one by one (as one part they would move as one rigid body); if it is one moulded part, give it a "
        "name of the catalogue or draw it of primitives",
        details={"submodels": headed[:MAX_SKIPPED_LISTED]})


PART_EXTENSIONS = (".dat", ".ldr", ".mpd", ".l3b")  # a type-1 line names its file with the extension
MODEL_EXTENSIONS = (".ldr", ".mpd")  # the library's parts are .dat files: these name (sub-)models


def _cut_last_line(text: str) -> int | None:
    """The number of the last line when it has no line ending and is a type-1 line cut short: editors end
    every line, and a cut that leaves 15 fields has cut the file name (its extension is gone)."""
    if not ends_mid_line(text):
        return None
    lines = text.splitlines()
    tokens = lines[-1].split()
    if not tokens or tokens[0] != "1":
        return None
    if len(tokens) >= 15 and lines[-1].split(None, 14)[14].strip().lower().endswith(PART_EXTENSIONS):
        return None
    return len(lines)


# Byte-order marks and zero-width characters carry nothing in LDraw: a BOM inside the text is where files saved by
# Notepad were joined into one .mpd; left in, it hides the '0 FILE' line it starts, and that sub-model's parts would be
# read as the previous section's, at the wrong place.
INVISIBLE = dict.fromkeys(map(ord, "\ufeff\u200b\u200c\u200d\u2060"))


def _refuse_a_part_drawing(lines: list[tuple[int, str]]) -> None:
    """A 422 for a file that is one part's (or primitive's) definition from the LDraw library, headed
    ``0 !LDRAW_ORG Part`` and drawing the part (lines 2-5, primitives such as stud.dat) without placing a catalogue
    part: it was answered as a model of unknown parts with 0 degrees of freedom, or 'places no part'."""
    kind = _section_type(lines)
    if kind not in PART_TYPES | GEOMETRY_TYPES or _catalogue_parts(lines):
        return
    header = next(t for _, raw in lines if len(t := raw.split()) >= 3 and t[0] == "0"
                  and t[1].upper().lstrip("!") == "LDRAW_ORG")
    name = next((raw.split(None, 2)[2].strip() for _, raw in lines
                 if raw.split()[:2] == ["0", "Name:"] and len(raw.split()) > 2), None)
    raise reject(f"the file is a part's drawing, not a model: its header '0 {' '.join(header[1:3])}' says it defines "
                 f"{'the part ' + repr(name) if name else 'one part'} (its lines draw that part's own geometry), and it "
                 "places no part; the rigidity kind analyses a model, an .ldr or .mpd whose type-1 lines place parts "
                 "(this one among them)")


def parse_ldraw(text: str) -> dict:
    text = text.translate(INVISIBLE)
    main, files, outside = _files(text)
    _refuse_a_part_drawing(files.get(main, []))
    roles = _classify(files, main)
    embedded: set[str] = set()
    parts: list[dict] = []
    skipped: list[dict] = []
    # a sub-model placed but not held, by its name's key (LDraw matches names whatever their case): the name as first
    # written, a held sub-file named alike, and the first MAX_SKIPPED_LISTED lines placing it
    missing: dict[str, tuple[str, str | None, dict[int, None]]] = {}
    warnings: list[dict] = []
    cut = _cut_last_line(text)
    counts = {"meta_lines": 0, "geometry_lines": 0, "submodels_expanded": 0, "rotations_rounded": 0,
              "mirrors_of_symmetric_parts": 0}
    placements: dict[str, str] = {}  # part id prefix of each placed sub-model -> its file name
    hand_typed: list[tuple[int, float]] = []  # (line, off) of sub-model placements read as the nearest rotation
    resolver = Resolver(files, lambda name: _resolve(name, files))
    from_primitives: dict[str, dict] = {}  # part number -> catalogue record, of embedded parts not in the catalogue
    mirrored: list[tuple[str, int, str]] = []  # (id, line, number) of parts whose placement mirrors them
    drawn: dict[int, str] = {}  # line -> file name, of subparts and primitives placed in a model
    stickers: set[str] = set()  # numbers of the parts the file defines whose header says they are stickers

    def draws_only(file_name: str, role: str | None) -> bool:
        """Whether the file a type-1 line places is a primitive or a subpart (stud.dat, no folder too): geometry
        drawn, no part."""
        return role == "geometry" or (role is None and (_key(file_name).startswith(GEOMETRY_FOLDERS) or (
            lookup(file_name) is None and official(file_name) is not None)))

    parts_in: dict[str, int] = {}

    def parts_placed_by(raw: str, stack: tuple[str, ...]) -> int:
        """How many parts a type-1 line places: a held sub-model's, expanded; a part one; a primitive, a sub-model
        the file lacks (submodels_missing says it) or one that includes itself none."""
        tokens = raw.split()
        if tokens[:1] != ["1"] or len(tokens) < 15:
            return 1 if tokens[:1] == ["1"] else 0
        file_name = raw.split(None, 14)[14].strip()
        sub = _resolve(file_name, files)
        role = roles.get(sub, "model") if sub is not None else None
        if draws_only(file_name, role) or (role is None and _key(file_name).endswith(MODEL_EXTENSIONS)):
            return 0
        if role != "model":
            return 1
        if sub in stack or len(stack) > MAX_DEPTH:
            return 0
        if sub not in parts_in:
            parts_in[sub] = sum(parts_placed_by(line, (*stack, sub)) for _, line in files[sub])
        return parts_in[sub]

    unread: list[tuple[int, str]] = []  # (line, NOT_READ or PAST_LIMIT) of the skipped lines that placed something

    def skip(number: int, reason: str, kind: str | None = None) -> None:
        skipped.append({"line": number, "reason": reason})
        if kind is not None:
            unread.append((number, kind))

    def expand(name: str, rot: np.ndarray, pos: np.ndarray, prefix: str, stack: tuple[str, ...]) -> None:
        for number, raw in files.get(name, []):
            tokens = raw.split()
            if not tokens:
                continue
            kind = tokens[0]
            if kind == "0":
                counts["meta_lines"] += 1
                continue
            if kind in ("2", "3", "4", "5"):
                counts["geometry_lines"] += 1
                continue
            if kind != "1":
                skipped.append({"line": number, "reason": f"line type {kind!r} is not an LDraw line type"})
                continue
            if number == cut:
                skip(number, "the file ends inside this line (no line ending, fields or the file name's extension "
                     "missing): not read", NOT_READ)
                continue
            if len(tokens) < 15:
                skip(number, f"a type-1 line needs 15 fields, this one has {len(tokens)}", NOT_READ)
                continue
            try:
                values = [float(t) for t in tokens[2:14]]
            except ValueError:
                comma = next((t for t in tokens[2:14] if _numbers(t) and "," in t), None)
                skip(number, "position or rotation is not a number" + (
                    f" ({comma!r}: a decimal comma; LDraw numbers take a decimal point)" if comma else ""), NOT_READ)
                continue
            if not np.isfinite(values).all():
                skip(number, "position or rotation is not finite", NOT_READ)
                continue
            file_name = raw.split(None, 14)[14].strip()
            local_pos = np.array(values[:3])
            local_rot = np.array(values[3:]).reshape(3, 3)
            sub = _resolve(file_name, files)
            role = roles.get(sub, "model") if sub is not None else None
            if draws_only(file_name, role):
                counts["geometry_lines"] += 1  # a primitive or subpart placed in a model draws (scaled or not)
                drawn.setdefault(number, file_name)
                continue
            if abs(np.linalg.det(local_rot)) < 1e-6:
                skip(number, "the rotation matrix is singular", NOT_READ)
                continue
            with np.errstate(over="ignore", invalid="ignore"):  # entries of 1e308: off is inf, the line skipped
                off = float(np.abs(local_rot @ local_rot.T - np.eye(3)).max())
            if off > (HAND_TYPED_ROTATION if role == "model" else ROUNDED_ROTATION):
                skip(number, f"the matrix is not a rotation (scaled or sheared: its rows are off orthonormal by "
                     f"{off:.3g})", NOT_READ)
                continue
            if off > ROUNDED_ROTATION:
                hand_typed.append((number, off))
            if off > 1e-12:
                # a rotation printed with few digits (0.707, 0.985 and 0.17): the nearest rotation, so that
                # sub-model placements composed of such matrices stay rotations
                u, _, vt = np.linalg.svd(local_rot)
                local_rot = u @ vt
                counts["rotations_rounded"] += 1
            world_rot = rot @ local_rot
            world_pos = rot @ local_pos + pos
            if not np.all(np.abs(world_pos) <= MAX_COORDINATE):  # NaN fails too: an absurd float, or its overflow
                skip(number, f"the position is beyond {MAX_COORDINATE:g} LDU", NOT_READ)
                continue
            ident = f"{prefix}L{number}"
            if role is None and _key(file_name).endswith(MODEL_EXTENSIONS):  # parts are .dat: this is a model
                if _key(file_name) not in missing:
                    missing[_key(file_name)] = (file_name, _named_alike(file_name, files), {})
                _, alike, placing = missing[_key(file_name)]
                if len(placing) < MAX_SKIPPED_LISTED:  # a line of a sub-model placed again is the same line
                    placing[number] = None
                skipped.append({"line": number, "reason": f"places sub-model {file_name!r}, which the file does not "
                                "hold " + (f"(it holds {alike!r}, named alike: a name misspelt, or its extension "
                                           "changed? names must match but for case)" if alike else
                                           "(an .mpd cut short, or an .ldr whose sub-models are separate files: send "
                                           "them as one .mpd)")})
                continue
            if role == "model":
                if sub in stack:
                    loop = " -> ".join([*stack[stack.index(sub):], sub])
                    skipped.append({"line": number, "reason": f"sub-model {file_name!r} includes itself ({loop})"})
                    continue
                if len(stack) >= MAX_DEPTH:
                    skip(number, f"sub-model {file_name!r} is nested more than {MAX_DEPTH} levels deep", NOT_READ)
                    continue
                # counted as it expands: a fan-out of sub-models (10 includes x 8 levels = 10^8 placements) is
                # refused once it passes the bound, before it expands further
                if len(parts) + counts["submodels_expanded"] >= MAX_PARTS:
                    raise reject(f"the model expands to more than {MAX_PARTS} parts and sub-model placements "
                                 f"(line {number} places {file_name!r} once more); at most {MAX_PARTS} are read")
                counts["submodels_expanded"] += 1
                if len(placements) < MAX_PLACEMENTS_LISTED:
                    placements[ident + "/"] = file_name
                expand(sub, world_rot, world_pos, ident + "/", (*stack, sub))
                continue
            if len(parts) >= MAX_PARTS:
                skip(number, f"more than {MAX_PARTS} parts", PAST_LIMIT)
                continue
            if np.linalg.det(world_rot) < 0 and lookup(file_name) is not None:  # unknown parts: not analysed
                planes = symmetry_planes(file_name)
                if not planes:
                    mirrored.append((ident, number, normalise_number(file_name)))
                else:  # the part's mirror image is itself turned: the same connections and boxes, as a rotation
                    # (any of its symmetries gives the same shape; the one that turns it least is kept)
                    world_rot = world_rot @ max(planes, key=lambda plane: np.trace(world_rot @ plane))
                    counts["mirrors_of_symmetric_parts"] += 1
            if role == "part":
                embedded.add(sub)
                number = normalise_number(file_name)
                if lookup(file_name) is None and category(raw for _, raw in files[sub]) == STICKER:
                    stickers.add(number)
                if number not in from_primitives and lookup(file_name) is None:
                    record = resolver.record(sub)
                    if record is not None:
                        from_primitives[number] = record
            parts.append({"id": ident, "part": normalise_number(file_name),
                          "position": [_tidy(v) for v in world_pos],
                          "rotation": [_tidy(v) for v in world_rot.reshape(-1)]})

    expand(main, np.eye(3), np.zeros(3), "", (main,))
    # what the skipped placements would have placed (a sub-model placed by a scaling matrix: all its parts), counted
    # before a line repeated by its sub-model's placements is said once: a verdict on the model needs the parts read
    # to be most of it (a placement a sub-model's missing section or its own loop skips is not counted:
    # submodels_missing says the one, the other places nothing). Bounded: a fan-out of sub-models places 10^30.
    raw_of = {number: raw for section in files.values() for number, raw in section}
    not_read = min(sum(parts_placed_by(raw_of.get(line, ""), (main,)) for line, kind in unread if kind == NOT_READ),
                   MAX_PARTS + 1)
    past_limit = min(sum(kind == PAST_LIMIT for _, kind in unread), MAX_PARTS + 1)
    # a line of a sub-model placed n times is skipped n times: one line of the file, said once
    first_of_line: dict[int, dict] = {}
    for entry in skipped:
        first_of_line.setdefault(entry["line"], entry)
    skipped = list(first_of_line.values())
    if hand_typed:
        worst = max(off for _, off in hand_typed)
        lines = sorted({n for n, _ in hand_typed})
        warnings.append(Diagnostic(
            code="rotation_rounded", message=f"{len(lines)} sub-model placement(s) have matrices off a rotation by "
            f"more than printing rounding ({ROUNDED_ROTATION:g}), up to {worst:.3g} (rotations typed by hand?), at "
            f"line {', '.join(map(str, lines[:10]))}{' and more' if len(lines) > 10 else ''}: each was read as the "
            "nearest rotation, so the sub-model's parts stand up to a few degrees off where the matrix puts them",
            details={"lines": lines[:MAX_SKIPPED_LISTED], "max_off": round(worst, 4)}).model_dump())
    if mirrored:
        warnings.append(mirrored_parts(mirrored).model_dump())
    if drawn:
        warnings.append(geometry_placed(drawn).model_dump())
    if (headed := _headed_parts_expanded(files, roles, main)) is not None:
        warnings.append(headed.model_dump())
    if outside:
        warnings.append(Diagnostic(
            code="lines_outside_files", message=f"{len(outside)} type-1 line(s) after a '0 NOFILE' and before any "
            f"'0 FILE' (line {', '.join(map(str, outside[:10]))}{' and more' if len(outside) > 10 else ''}) belong "
            "to no model: LDraw readers ignore them, and so were they — lines pasted after the model's end, or a "
            "'0 FILE' line lost?", details={"lines": outside[:MAX_SKIPPED_LISTED], "count": len(outside)}).model_dump())
    placed = _placed_submodels(main, files, roles)
    unplaced = [name for name, role in roles.items() if role == "model" and name not in placed
                and any(raw.split()[:1] == ["1"] for _, raw in files[name])]
    if unplaced:
        warnings.append(Diagnostic(
            code="unplaced_submodels", message=f"{len(unplaced)} sub-model(s) of the file are not placed in the main "
            f"model {main!r}, directly or through its sub-models ({', '.join(repr(n) for n in unplaced[:5])}"
            f"{' and more' if len(unplaced) > 5 else ''}): their parts are not analysed (a leftover of editing, or "
            "the main model is another one)",
            details={"submodels": unplaced[:MAX_SKIPPED_LISTED], "main_model": main}).model_dump())
    if cut is not None:
        warnings.append(truncated_file(cut, "the file ends inside this type-1 line (the file was cut?); the part it "
                                       "placed was not read.").model_dump())
    elif ends_mid_line(text) and text.splitlines()[-1].split()[:1] != ["1"]:
        # a comment or meta line cut (a whole part line is taken as written, as _cut_last_line says): what followed
        # it is gone
        last = len(text.splitlines())
        warnings.append(truncated_file(last, "its last line has no line ending (the file was cut?): it was read as "
                                       "written, and whatever the file held after it is missing.").model_dump())
    if not parts:
        other = other_format(text)
        if other:
            raise reject(f"the file is not LDraw: it holds {other}; the rigidity kind reads LDraw models (.ldr, "
                         ".mpd: type-1 lines placing parts) or a rigidity request as .json")
        if outside:
            raise reject(f"the file places no part: its type-1 lines (line {', '.join(map(str, outside[:5]))}"
                         f"{' …' if len(outside) > 5 else ''}) come after a '0 NOFILE' with no '0 FILE' before them, "
                         "where they belong to no model; move them above it, or give them a '0 FILE' line")
        reasons = "; ".join(f"line {s['line']}: {s['reason']}" for s in skipped[:5])
        raise reject("the file places no part (no usable type-1 line)" + (f" — {reasons}" if reasons else ""))
    return {"parts": parts, "source": {"format": "ldraw", "units": LDRAW_UNITS, "main_model": main,
                                       "parts": len(parts),
                                       "submodels": sum(r == "model" for n, r in roles.items() if n != main),
                                       "embedded_parts": sorted(embedded), **counts,
                                       "parts_from_primitives": from_primitives,
                                       "stickers_defined": sorted(stickers),
                                       "submodel_placements": placements,
                                       "missing_submodels": {name: list(lines) for name, _, lines
                                                             in list(missing.values())[:MAX_SKIPPED_LISTED]},
                                       "missing_submodels_count": len(missing),
                                       "skipped": skipped[:MAX_SKIPPED_LISTED], "skipped_count": len(skipped),
                                       "placements_not_read": not_read, "parts_past_limit": past_limit,
                                       "warnings": warnings}}


# The 24 signed permutations of the frame's axes of each handedness. The improper ones are the mirrors about its x,
# y and z planes, about its diagonal planes (a corner plate 2420 or brick 2357 is symmetric about x = z), and those
# times a rotation; the proper ones the turns that may take a part onto itself (a 2 x 4 brick's half turn about y).
SIGNED_PERMUTATIONS = tuple(np.diag(signs)[list(perm)] for perm in itertools.permutations(range(3))
                            for signs in itertools.product((1.0, -1.0), repeat=3))
MIRRORS = tuple(m for m in SIGNED_PERMUTATIONS if np.linalg.det(m) < 0)
TURNS = tuple(m for m in SIGNED_PERMUTATIONS if np.linalg.det(m) > 0)
# Points whose bore or grip is centred on them, so that their direction's sign says nothing (a through hole).
CENTRED = frozenset({"pinhole", "axlehole", "barhole", "clip", "rodclip", "hole"})


def _onto_itself(file_name: str, frames: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    """The ``frames`` that map the part's catalogue shape — every connection point with its direction (a through
    hole's either way), type and profile, its bounding box and solids — onto itself; none for a part not in the
    catalogue."""
    shape = lookup(file_name)
    if shape is None:
        return ()

    def direction(frame: np.ndarray, c) -> list:
        d = np.round(frame @ c.direction, 6)
        if c.type in CENTRED and c.length <= 0 and d[np.flatnonzero(d)[:1]].sum() < 0:
            d = -d
        return (d + 0.0).tolist()

    def drawn(frame: np.ndarray) -> tuple[list, list]:
        """The connections and boxes of the shape in ``frame``, rounded, in a canonical order."""
        connections = sorted((*np.round(frame @ c.point, 6).tolist(), *direction(frame, c),
                              c.type, c.length, c.profile, c.depth) for c in shape.connectors)
        boxes = sorted((*np.round(frame @ centre, 6).tolist(), *np.round(np.abs(frame) @ size, 6).tolist())
                       for centre, size in ((shape.box_center, shape.box_size), *shape.solids))  # axes swapped too
        return connections, boxes

    own = drawn(np.eye(3))
    return tuple(frame for frame in frames if drawn(frame) == own)


@functools.lru_cache(maxsize=1024)
def symmetry_planes(file_name: str) -> tuple[np.ndarray, ...]:
    """The mirrors of the part's frame (:data:`MIRRORS`) that map its catalogue shape onto itself; none for a
    handed part or one not in the catalogue. Placed mirrored, such a part is the same as placed by the matrix times
    one of these mirrors, a rotation."""
    return _onto_itself(file_name, MIRRORS)


@functools.lru_cache(maxsize=1024)
def symmetry_turns(file_name: str) -> tuple[np.ndarray, ...]:
    """The turns of the part's frame (:data:`TURNS`, the identity among them) that map its catalogue shape onto
    itself: placed by the matrix times any of them, the part is where it was (a 2 x 4 brick turned half about its
    y axis). Only the identity for a part not in the catalogue."""
    return _onto_itself(file_name, TURNS) or (np.eye(3),)


SUBPART = re.compile(r"(?:parts/)?s/(\w+?)s\d+[a-z]?\.dat$")


def geometry_placed(drawn: dict[int, str]) -> Diagnostic:
    """Subparts and primitives placed by a model's own lines: drawn geometry, no part, so not analysed. A user who
    typed a subpart's name (``s\\3001s01.dat``) for its part (3001) sees the part it belongs to named."""
    lines = sorted(drawn)

    def named(line: int) -> str:
        found = SUBPART.match(_key(drawn[line]))
        return f"line {line}: '{drawn[line]}'" + (f" (a subpart of {found.group(1)})" if found else "")

    return Diagnostic(
        code="geometry_placed", message=f"{len(lines)} line(s) of a model place a subpart or primitive, drawn "
        f"geometry that is no part: {'; '.join(named(line) for line in lines[:10])}{' and more' if len(lines) > 10 else ''}"
        ". They were not analysed (no connection, no collision shape: a part drawn so, a bent hose's segments "
        "among them, is missing from the analysis); where a part was meant, place the part itself (3001.dat, not "
        "s\\3001s01.dat).",
        details={"lines": lines[:MAX_SKIPPED_LISTED], "files": [drawn[line] for line in lines[:MAX_SKIPPED_LISTED]],
                 "count": len(lines)})


def mirrored_parts(mirrored: list[tuple[str, int, str]]) -> Diagnostic:
    """Parts placed by a matrix of negative determinant (their own line's, or a mirrored sub-model's): no brick can be
    built mirrored. A symmetric part's mirror image is one of its rotations; a handed part's (a left wing plate) is
    its twin of the other hand, another part number, whose connections the mirrored one only stands in for."""
    lines = sorted({line for _, line, _ in mirrored})
    numbers = sorted({number for _, _, number in mirrored})
    return Diagnostic(
        code="mirrored_parts", message=f"{len(mirrored)} part(s) are placed mirrored (a matrix of negative "
        f"determinant), at line {', '.join(map(str, lines[:10]))}{' and more' if len(lines) > 10 else ''} "
        f"({', '.join(numbers[:10])}{' …' if len(numbers) > 10 else ''}): no part can be built mirrored — a "
        "handed part's mirror image is its twin of the other hand, another part number. They were analysed as "
        "drawn; replace each by its twin, or by a rotation if it is symmetric.",
        details={"parts": [ident for ident, _, _ in mirrored[:MAX_SKIPPED_LISTED]], "lines": lines[:MAX_SKIPPED_LISTED],
                 "numbers": numbers[:MAX_SKIPPED_LISTED]})


LINE_TYPES = {"0", "1", "2", "3", "4", "5"}
OBJ_KEYWORDS = {"v", "vn", "vt", "f", "o", "g", "s", "l", "usemtl", "mtllib"}
SNIFFED_LINES = 200


def other_format(text: str) -> str | None:
    """What a text that is no LDraw holds, when its first lines say so (a mesh, a building model, a table …):
    a phrase for the refusal, or None."""
    lines = [raw.strip() for raw in text.splitlines()[:SNIFFED_LINES] if raw.strip()]
    if not lines:
        return None
    head = lines[0]
    first_tokens = [raw.split()[0] for raw in lines if not raw.startswith("#")]
    if head.startswith("ISO-10303-21"):
        schema = next((raw for raw in lines if raw.upper().startswith("FILE_SCHEMA")), "")
        return "an IFC model (ISO-10303-21)" if "IFC" in schema.upper() else "a STEP model (ISO-10303-21)"
    if head.lower().startswith("solid") and any(raw.lower().startswith("facet") for raw in lines):
        return "an ASCII STL mesh (solid, facet normal, vertex lines)"
    upper = {raw.upper() for raw in lines}
    if "SECTION" in upper and upper & {"HEADER", "ENTITIES", "TABLES", "EOF"}:
        return "a DXF drawing (group codes and SECTION / ENTITIES names)"
    if head.startswith("<"):
        root = next((raw[1:].split()[0].rstrip(">") for raw in lines if raw.startswith("<") and
                     not raw.startswith(("<?", "<!"))), "?")
        return f"an XML document (root element <{root}>: gbXML, IFC-XML or another)"
    if head.startswith(("{", "[")):
        return "a JSON document (send a rigidity request as a .json file)"
    if any(raw.upper().startswith(("ISO-TOP-HEADER", "PIPELINE-REFERENCE", "UNITS-BORE")) for raw in lines):
        return "a PCF piping file (ISO-TOP-HEADER, PIPELINE-REFERENCE … lines)"
    if first_tokens and sum(t in OBJ_KEYWORDS for t in first_tokens) >= max(1, len(first_tokens) // 2):
        vertices = sum(t == "v" for t in first_tokens)
        faces = sum(t == "f" for t in first_tokens)
        return (f"a Wavefront OBJ mesh ({vertices} vertex and {faces} face lines among its first "
                f"{len(lines)}: 'v x y z', 'f i j k')")
    fields = [kept for raw in lines if (kept := raw.split("!")[0].strip())]  # an IDF's '!' comments set aside
    if any(raw.endswith(";") for raw in fields) and sum("," in raw for raw in fields) >= len(fields) // 2:
        objects = sorted({raw.split(",")[0].strip() for raw in lines if "," in raw and "!-" not in raw  # not a field
                          and raw.split(",")[0].strip() and raw.split(",")[0].strip()[0].isalpha()})[:5]
        return "an EnergyPlus IDF building model (objects such as " + ", ".join(objects) + ")"
    delimiter = next((d for d in (",", ";", "\t") if all(d in raw for raw in lines[:5])), None)
    ldraw_lines = all(raw.split()[0] in LINE_TYPES and len(raw.split()) >= 8 for raw in lines[:5])
    if delimiter is not None and not ldraw_lines:  # LDraw lines with decimal commas are no table
        columns = [c.strip() for c in lines[0].split(delimiter)]
        return f"a table of {len(columns)} columns ({', '.join(columns[:8])})"
    if all(_numbers(raw) for raw in lines[:20]) and lines[0].split()[0] not in LINE_TYPES:
        return f"a list of numbers, {len(lines[0].split())} per line (a point cloud or a scan, not part placements)"
    return None


def _numbers(raw: str) -> bool:
    try:
        [float(t) for t in raw.replace(",", " ").split()]
    except ValueError:
        return False
    return True


def _tidy(v: float) -> float:
    """Exporters write 0.999999 or -0 for 1 and 0: values within 1e-5 of an integer become it."""
    r = round(float(v))
    return float(r) if abs(v - r) < 1e-5 else float(v)


FORM = FormRules(RigidityRequest, units="file")


def parse_upload(source: StoredInput, options: dict | None) -> RigidityRequest:
    """An LDraw or JSON file (intake checked the extension) as a request, with the upload form's ``options``
    (``units``, ``contact_tolerance``, ``dock``, ``rank_tolerance``) joined to it by the rules of
    :mod:`plantsolve.solvers.upload_form`."""
    content = source.read()
    if not content.strip():
        raise reject("the file is empty")
    text = decode_text(content, "LDraw or JSON file")
    body = json_object(text) if source.extension == ".json" else parse_ldraw(text)
    if source.extension == ".json":
        _refuse_other_request(body)
    request = request_of_file(body, options, FORM)
    if source.extension != ".json" and isinstance(options, dict) and options.get("units") is not None:
        request.source["warnings"].append(_form_units_not_used(request.units, options))
    return request


def _form_units_not_used(units: str, options: dict) -> dict:
    """The form's ``units`` beside an LDraw file, which states its own: its positions, the result's lengths and
    ``contact_tolerance`` are LDU whatever the form says (a tolerance meant in millimetres is 2.5 times as large in
    LDU), so the unit the user meant is said not to be used."""
    tolerance = options.get("contact_tolerance", (options.get("options") or {}).get("contact_tolerance")
                            if isinstance(options.get("options"), dict) else None)
    said = (f"; contact_tolerance {tolerance} is read in LDU too ({float(tolerance) * 0.4:g} mm), not in {units}"
            if isinstance(tolerance, (int, float)) and not isinstance(tolerance, bool) else "")
    return Diagnostic(code="units_not_used", message=(
        f"options.units {units!r} is not used: an LDraw file states its own unit, the LDraw unit (1 LDU = 0.4 mm), in "
        f"which its positions are read and the result's lengths are given{said}. options.units applies to the bodies "
        "of a JSON request."), details={"units": units, "file_unit": "ldu",
                                        "contact_tolerance_ldu": tolerance if said else None}).model_dump()


MODEL_FIELDS = ("bodies", "joints", "parts")


def _refuse_other_request(body: dict) -> None:
    """A JSON object without any of a rigidity request's model fields is another kind's request (or no request):
    refused naming what it holds, and the kind whose request has those fields, when one has."""
    if any(key in body for key in MODEL_FIELDS):
        return
    keys = sorted(str(k) for k in body)[:12]
    kind = other_kind(set(body))
    held = f"{'an' if kind and kind[0] in 'aeiou' else 'a'} {kind} request" if kind else "no rigidity model"
    raise reject(f"the JSON file holds {held} (its fields: {', '.join(keys) or 'none'}); a rigidity request holds "
                 "'parts' (LEGO parts) or 'bodies' and 'joints'")


def other_kind(keys: set[str]) -> str | None:
    """The kind whose request schema has every one of ``keys`` among its fields (and needs no field they lack),
    or None."""
    requests = {"alignment": alignment.AlignmentRequest, "dedup": dedup.DedupRequest,
                "flowmeter": flowmeter.FlowmeterRequest, "perfmap": perfmap.PerfmapRequest,
                "polyhedra": polyhedra.PolyhedraRequest, "tube": tube.TubeRequest}
    best = None
    for kind, model in requests.items():
        fields = set(model.model_fields)
        required = {n for n, f in model.model_fields.items() if f.is_required()}
        shared = keys & fields - {"units", "options", "source", "name"}
        if shared and keys <= fields and required <= keys and (best is None or len(shared) > best[1]):
            best = (kind, len(shared))
    return best[0] if best else None
