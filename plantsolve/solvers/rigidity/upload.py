"""Files a model comes in: LDraw ``.ldr`` / ``.mpd`` (type-1 part lines) or a JSON request.

LDraw as LDCad, LeoCAD, MLCad and BrickLink Studio write it: a line's first token is its type.
Type 1 is ``1 <colour> x y z a b c d e f g h i <file>`` (position in LDU, the rotation row-major,
the file name possibly with spaces and in any case, with or without ``.dat``); it places a part,
or a sub-model of the same ``.mpd``, which is expanded with its placement composed (sub-models of
sub-models too; a sub-model that includes itself is refused at that line). Type 0 lines are
comments and meta commands (``0 FILE`` and ``0 NOFILE`` delimit the sub-files of an ``.mpd``;
``0 STEP``, ``0 !LDCAD …``, ``0 !LEOCAD …``, ``0 MLCAD …``, ``0 ROTSTEP``, ``0 BFC`` and the rest
are ignored), types 2–5 are drawn geometry (lines, triangles, quads) and ignored, colours are
ignored. Item by item: a type-1 line that cannot be read is skipped and listed in the report with
its line and reason; parts not in the catalogue are kept and reported as unknown by the solver
(never guessed); the file is refused (422 naming the file) only when it places no part at all.
Part ids are ``L<line>`` in the main model and ``<parent id>/L<line>`` inside sub-models.
"""

from __future__ import annotations


import numpy as np

from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.solvers.base import StoredInput, decode_text, json_object, reject
from plantsolve.solvers.rigidity.catalogue import normalise_number
from plantsolve.solvers.skipped_input import ends_mid_line, truncated_file
from plantsolve.solvers.upload_form import validated_upload

UPLOAD_EXTENSIONS = (".ldr", ".mpd", ".json")
MAX_DEPTH = 32
MAX_SKIPPED_LISTED = 200
MAX_PARTS = 20_000


def _files(text: str) -> tuple[str, dict[str, list[tuple[int, str]]]]:
    """The main model's name and every sub-file's numbered lines (one unnamed file for a plain .ldr)."""
    files: dict[str, list[tuple[int, str]]] = {}
    main = None
    current = None
    for number, raw in enumerate(text.splitlines(), 1):
        tokens = raw.split()
        if len(tokens) >= 2 and tokens[0] == "0" and tokens[1].upper() == "FILE":
            current = raw.strip()[1:].strip()[4:].strip().lower()
            files.setdefault(current, [])
            main = main or current
            continue
        if len(tokens) >= 2 and tokens[0] == "0" and tokens[1].upper() == "NOFILE":
            current = ""  # text between files belongs to no model
            continue
        if current is None:
            current = main = "<main>"
            files.setdefault(current, [])
        if current:
            files[current].append((number, raw))
    return main or "<main>", files


PART_EXTENSIONS = (".dat", ".ldr", ".mpd", ".l3b")  # a type-1 line names its file with the extension


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


def parse_ldraw(text: str) -> dict:
    main, files = _files(text)
    parts: list[dict] = []
    skipped: list[dict] = []
    warnings: list[dict] = []
    cut = _cut_last_line(text)
    counts = {"meta_lines": 0, "geometry_lines": 0, "submodels_expanded": 0}

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
                skipped.append({"line": number, "reason": "the file ends inside this line (no line ending, "
                                "fields or the file name's extension missing): not read"})
                continue
            if len(tokens) < 15:
                skipped.append({"line": number, "reason": f"a type-1 line needs 15 fields, this one has {len(tokens)}"})
                continue
            try:
                values = [float(t) for t in tokens[2:14]]
            except ValueError:
                skipped.append({"line": number, "reason": "position or rotation is not a number"})
                continue
            if not np.isfinite(values).all():
                skipped.append({"line": number, "reason": "position or rotation is not finite"})
                continue
            file_name = raw.split(None, 14)[14].strip()
            local_pos = np.array(values[:3])
            local_rot = np.array(values[3:]).reshape(3, 3)
            if abs(np.linalg.det(local_rot)) < 1e-6:
                skipped.append({"line": number, "reason": "the rotation matrix is singular"})
                continue
            world_rot = rot @ local_rot
            world_pos = rot @ local_pos + pos
            ident = f"{prefix}L{number}"
            sub = file_name.lower()
            if sub in files:
                if sub in stack or len(stack) >= MAX_DEPTH:
                    skipped.append({"line": number, "reason": f"sub-model {file_name!r} includes itself"})
                    continue
                # counted as it expands: a fan-out of sub-models (10 includes x 8 levels = 10^8 placements) is
                # refused once it passes the bound, before it expands further
                if len(parts) + counts["submodels_expanded"] >= MAX_PARTS:
                    raise reject(f"the model expands to more than {MAX_PARTS} parts and sub-model placements "
                                 f"(line {number} places {file_name!r} once more); at most {MAX_PARTS} are read")
                counts["submodels_expanded"] += 1
                expand(sub, world_rot, world_pos, ident + "/", (*stack, sub))
                continue
            if len(parts) >= MAX_PARTS:
                skipped.append({"line": number, "reason": f"more than {MAX_PARTS} parts"})
                continue
            parts.append({"id": ident, "part": normalise_number(file_name),
                          "position": [_tidy(v) for v in world_pos],
                          "rotation": [_tidy(v) for v in world_rot.reshape(-1)]})

    expand(main, np.eye(3), np.zeros(3), "", (main,))
    if cut is not None:
        warnings.append(truncated_file(cut, "the file ends inside this type-1 line (the file was cut?); the part it "
                                       "placed was not read.").model_dump())
    if not parts:
        reasons = "; ".join(f"line {s['line']}: {s['reason']}" for s in skipped[:5])
        raise reject("the file places no part (no usable type-1 line)" + (f" — {reasons}" if reasons else ""))
    return {"parts": parts, "source": {"format": "ldraw", "main_model": main, "parts": len(parts),
                                       "submodels": max(len(files) - 1, 0), **counts,
                                       "skipped": skipped[:MAX_SKIPPED_LISTED], "skipped_count": len(skipped),
                                       "warnings": warnings}}


def _tidy(v: float) -> float:
    """Exporters write 0.999999 or -0 for 1 and 0: values within 1e-5 of an integer become it."""
    r = round(float(v))
    return float(r) if abs(v - r) < 1e-5 else float(v)


def parse_upload(source: StoredInput, options: dict | None) -> RigidityRequest:
    """An LDraw or JSON file (intake checked the extension) as a request; ``options`` (the form's:
    ``contact_tolerance``, ``dock``, ``rank_tolerance``) override what the file says."""
    content = source.read()
    if not content.strip():
        raise reject("the file is empty")
    text = decode_text(content, "LDraw or JSON file")
    body = json_object(text) if source.extension == ".json" else parse_ldraw(text)
    return validated_upload(RigidityRequest, body, options)
