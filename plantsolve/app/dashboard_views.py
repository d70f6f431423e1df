"""What the dashboard's templates show of a job: plain values computed from the API's job view,
so a page and the JSON a browser receives live (``GET /v1/jobs/{id}``, its events) agree."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from datetime import datetime
from functools import lru_cache
from typing import Any

from pydantic import BaseModel, create_model

from plantsolve.app.verdicts import report_warnings
from plantsolve.schemas.common import ReportVerdict, verdicts_of
from plantsolve.schemas.jobs import ArtifactInfo, JobView
from plantsolve.solvers.base import SolverSpec

# larger inputs are offered as a download instead of being printed into the page
INLINE_INPUT_CHARS = 60_000
SUMMARY_ROWS = 40


def when(value: datetime | None) -> str:
    return value.strftime("%Y-%m-%d %H:%M:%S") if value else ""


def seconds(value: float | None) -> str:
    if value is None:
        return ""
    return f"{value:.2f} s" if value < 120 else f"{value / 60:.1f} min"


def progress_text(status: str, fraction: float) -> str:
    """The progress column: a share only while running. A running job whose solver is through
    (1.0) is still storing its result: it says so instead of '100 %'."""
    if status == "queued":
        return "waiting"
    if status == "running":
        return "storing result" if fraction >= 1.0 else f"{fraction:.0%}"
    return {"succeeded": "done", "failed": "failed", "cancelled": "cancelled"}[status]


def warning_count(view: JobView) -> int:
    return len(view.report.warnings) if view.report is not None else 0


@dataclass(frozen=True)
class Row:
    """One line of the job list."""

    id: str
    kind: str
    status: str
    fraction: float
    progress: str
    warnings: int
    message: str
    attempt: str
    created: str
    run: str
    input: str = "JSON"
    first_warning: str = ""  # the report's first warning's code (a kind puts its gravest first: a failed inspection)
    first_warning_message: str = ""
    verdict: ReportVerdict | None = None  # a warning that is a verdict against the result: shown beside 'succeeded'


def input_label(job: Any) -> str:
    """The list's input column: the uploaded file's name, or 'JSON' for a JSON body."""
    return (job.input_filename or "upload") if job.input_kind == "upload" else "JSON"


def row(view: JobView, input: str = "JSON") -> Row:
    report = view.report
    first = report.warnings[0] if report is not None and report.warnings else None
    message = (report.message if report is not None and report.message else "") or view.progress.message
    if view.status in ("queued", "running"):
        message = view.progress.message
    return Row(
        id=str(view.id),
        kind=view.kind,
        status=view.status,
        fraction=view.progress.fraction,
        progress=progress_text(view.status, view.progress.fraction),
        warnings=warning_count(view),
        message=message[:200],
        attempt=f"{view.attempt}/{view.max_attempts}",
        created=when(view.timings.created_at),
        run=seconds(view.timings.run_seconds),
        input=input,
        first_warning=first.code if first is not None else "",
        first_warning_message=first.message[:300] if first is not None else "",
        verdict=next(iter(verdicts_of(report_warnings(report))), None) if view.status == "succeeded" else None,
    )


def pretty(value: Any, indent: str = "") -> str:
    """JSON for people: objects one member a line, a list of numbers or strings on one line (a point
    [x, y, z] stays readable, and a scan's 10,000 points do not become 30,000 lines)."""
    inner = indent + "  "
    if isinstance(value, dict) and value:
        members = (f"{inner}{json.dumps(str(k), ensure_ascii=False)}: {pretty(v, inner)}" for k, v in value.items())
        return "{\n" + ",\n".join(members) + "\n" + indent + "}"
    if isinstance(value, list) and any(isinstance(v, (dict, list)) for v in value):
        return "[\n" + ",\n".join(inner + pretty(v, inner) for v in value) + "\n" + indent + "]"
    return json.dumps(value, ensure_ascii=False, allow_nan=True, separators=(", ", ": "))


_PLACEHOLDER = re.compile(r"\{([A-Za-z_][A-Za-z0-9_.]*)\}")


@lru_cache(maxsize=64)
def _schema(model: type[BaseModel]) -> dict[str, Any]:
    return model.model_json_schema(mode="serialization")


def _property(schema: dict[str, Any], defs: dict[str, Any], name: str) -> dict[str, Any] | None:
    """The schema of the member ``name`` of an object schema (through references and ``X | None``)."""
    stack = [schema]
    while stack:
        node = stack.pop()
        if "$ref" in node:
            node = defs.get(node["$ref"].rsplit("/", 1)[-1], {})
        if name in (node.get("properties") or {}):
            return node["properties"][name]
        stack.extend(node.get("anyOf", []) + node.get("allOf", []))
    return None


def field_unit(model: type[BaseModel] | None, result: Any, path: tuple[str, ...]) -> str:
    """The unit of the result field at ``path`` as the result model states it (``x-unit``), its placeholders
    (``{units}``, ``{units.flow}``) filled from the result itself; ``""`` where none is stated (counts, names)."""
    if model is None:
        return ""
    root = _schema(model)
    defs, node, unit = root.get("$defs", {}), root, ""
    for name in path:
        inner = _property(node, defs, name)
        if inner is None:  # a member of a mapping (timings.parse): the mapping's unit is its values'
            return _filled(unit, result) if node.get("additionalProperties") else ""
        node, unit = inner, inner.get("x-unit") or ""
        if not unit and "$ref" in inner:
            unit = defs.get(inner["$ref"].rsplit("/", 1)[-1], {}).get("x-unit", "")
    return _filled(unit, result)


NOT_STATED = "not stated"


def _filled(unit: Any, result: Any) -> str:
    """``unit`` with each ``{field}`` replaced by the unit the result's field holds (``{units.settings.0}``: the
    first of a list); :data:`NOT_STATED` for the whole unit when a field it names holds none (a request that stated
    no units), never the placeholder itself."""
    unstated = False

    def fill(match: re.Match) -> str:
        nonlocal unstated
        value: Any = result
        for key in match.group(1).split("."):
            if isinstance(value, dict):
                value = value.get(key)
            elif isinstance(value, list) and key.isdigit() and int(key) < len(value):
                value = value[int(key)]
            else:
                value = None
        if isinstance(value, list) and value and all(isinstance(v, str) for v in value):  # one unit per column
            return "per column: " + ", ".join(value)
        if isinstance(value, str):
            return value
        unstated = True
        return ""

    if not isinstance(unit, str):
        return ""
    filled = _PLACEHOLDER.sub(fill, unit)
    return NOT_STATED if unstated else filled


def result_summary(result: Any, model: type[BaseModel] | None = None) -> list[tuple[str, str, str]]:
    """The result's scalar fields (two levels deep) for people, each with its unit (from ``model``, the kind's
    result model; ``1``: a pure number); lists and objects by their size. The full result is one link away."""
    rows: list[tuple[str, str, str]] = []

    def describe(value: Any) -> str:
        if value is None:
            return "—"
        if isinstance(value, float):
            return f"{value:.6g}"
        if isinstance(value, list):
            if 0 < len(value) <= 4 and all(isinstance(v, (int, float, str)) for v in value):
                return "[" + ", ".join(describe(v) for v in value) + "]"
            return f"list of {len(value)}"
        if isinstance(value, dict):
            return f"object with {len(value)} field(s)"
        return str(value)

    def numeric(value: Any) -> bool:
        if isinstance(value, list):
            return bool(value) and all(map(numeric, value))
        return isinstance(value, (int, float)) and not isinstance(value, bool)

    def unit(value: Any, *path: str) -> str:
        return field_unit(model, result, path) if numeric(value) else ""

    if not isinstance(result, dict):
        return [("result", describe(result), "")]
    for key, value in result.items():
        if key == "report":  # shown in full on its own
            continue
        if isinstance(value, dict) and 0 < len(value) <= 12:
            rows += [(f"{key}.{sub}", describe(v), unit(v, key, sub)) for sub, v in value.items()]
        else:
            rows.append((key, describe(value), unit(value, key)))
    return rows[:SUMMARY_ROWS]


@dataclass(frozen=True)
class InputView:
    """How the job's input is shown: JSON printed, or the uploaded file's name with its options."""

    kind: str  # json | json_file | upload
    text: str | None  # pretty JSON when small enough to print
    filename: str | None
    options: str | None
    url: str


def input_view(job: Any) -> InputView:
    url = f"/v1/jobs/{job.id}/input"
    if job.input_kind == "json":
        text = pretty(job.input)
        return InputView("json", text if len(text) <= INLINE_INPUT_CHARS else None, None, None, url)
    if job.input_kind == "upload":  # /input describes an upload; its bytes are at /input/file
        options = pretty(job.input_options) if job.input_options else None
        return InputView("upload", None, job.input_filename, options, f"{url}/file")
    return InputView("json_file", None, "request.json", None, url)


def plots(artifacts: list[ArtifactInfo]) -> list[ArtifactInfo]:
    """The images to show inline: every raster image, and a vector one only when no raster image
    has its name (kinds write each plot as PNG and SVG; the SVG is for downloading)."""
    raster = [a for a in artifacts if a.media_type in ("image/png", "image/jpeg")]
    stems = {a.name.rsplit(".", 1)[0] for a in raster}
    vector = [a for a in artifacts if a.media_type == "image/svg+xml" and a.name.rsplit(".", 1)[0] not in stems]
    return raster + vector


def options_model(spec: SolverSpec) -> type[BaseModel]:
    """What an upload's ``options`` may set: the kind's options model (the request's ``options`` field); a kind
    without one (a plugin's) takes its options as the request's fields that have defaults."""
    field = spec.request_model.model_fields.get("options")
    if field is not None and isinstance(field.annotation, type) and issubclass(field.annotation, BaseModel):
        return field.annotation
    fields = {name: (f.annotation, f) for name, f in spec.request_model.model_fields.items() if not f.is_required()}
    return create_model(f"{spec.request_model.__name__}UploadOptions", **fields)


# The kinds whose upload readers take the request's ``units`` (the unit of every number of the result) from the
# form beside their options: a file's numbers are converted into it. Other kinds refuse the key (their unit comes
# from the file, or they have none).
UNITS_FROM_UPLOAD_FORM = frozenset({"tube", "polyhedra", "rigidity"})


def upload_units(spec: SolverSpec) -> tuple[list[str], str] | None:
    """The choices and default of the upload form's result unit (the request's ``units``), None for a kind whose
    upload takes none."""
    field = spec.request_model.model_fields.get("units")
    if spec.kind not in UNITS_FROM_UPLOAD_FORM or field is None:
        return None
    choices = spec.request_model.model_json_schema()["properties"]["units"].get("enum")
    return (list(choices), str(field.default)) if choices else None


def options_schema(spec: SolverSpec) -> dict[str, Any]:
    """The JSON schema the submit page's option form is generated from (by static/dashboard.js)."""
    return options_model(spec).model_json_schema()


def option_defaults(spec: SolverSpec) -> dict[str, Any]:
    """The upload form's options as first shown: every option's default (those without one, or null, are left
    out: the kind decides)."""
    defaults = {}
    for name, field in options_model(spec).model_fields.items():
        if field.is_required():
            continue
        value = field.get_default(call_default_factory=True, validated_data={})
        if value is None:
            continue
        defaults[name] = value.model_dump(mode="json") if isinstance(value, BaseModel) else value
    return json.loads(json.dumps(defaults, default=str))


def changed_options(sent: dict | None, shown: dict | None) -> dict | None:
    """The options to send with an upload: those that differ from the kind's defaults (``shown``). An option left
    at its default is not sent, so a JSON file's own options are not overridden by a default it never saw."""
    if not sent:
        return None
    changed = {k: v for k, v in sent.items() if not (shown and k in shown and shown[k] == v)}
    return changed or None
