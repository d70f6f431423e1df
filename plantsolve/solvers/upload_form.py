"""The upload form's options beside an uploaded file: one rule set for every kind.

The multipart ``options`` part is a JSON object holding the request's ``units`` and its options, flat
(``{"units": "in", "tolerance": 0.5}``) or nested as a request holds them (``{"options": {"tolerance": 0.5}}``).
A refusal names each value where the user wrote it: the form's as ``options.units``, ``options.tolerance`` or
``options.options.tolerance``; a request file's by its path in the file, ``file.units``, ``file.options.tolerance``.

The rules, the same for every kind (:func:`read_form`, :func:`merged`, :func:`validated_request`):

- The form may set any option of the kind's request; a request file (an uploaded ``.json``) any field of it.
- An option the form and the file both give is taken when they agree once read (``"6"`` and ``6``) and refused
  naming both places when they do not: which of them is meant is not known (the form may carry values nobody typed
  for this file, the dashboard fills in the kind's example options; the file is a request someone saved), and
  solving with either one without a word solves another problem than the other states.
- The form's ``units``, as the kind's :class:`FormRules` says:

  - ``"file"`` (alignment, flowmeter, rigidity, tube): the unit of the request's numbers. The form gives it to a
    file that states none (a file the reader turns into a request, a request file without ``units``); a request
    file that states one may have it repeated, never contradicted: its numbers relabelled would be a wrong answer
    that no warning tells.
  - ``"result"`` (polyhedra): the result's unit; the kind's reader converts the file's lengths into it and says so.
  - ``"quantities"`` (perfmap): the units of quantities the file leaves unstated (``{"flow": "kg/s"}``), which the
    kind's reader reads and checks against the file's own.
  - ``None`` (dedup): the request has no unit; the form's is refused naming it, saying why.

A kind's reader may refuse more for a format of its own (a PCF states its units; a tube scan's ``file_units``
means nothing beside a request file): those refusals name the form's fields as these do.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cache
from typing import Any, Callable, Literal, get_args, get_origin

from pydantic import BaseModel, create_model

from plantsolve.solvers.base import FieldError, InputRejected, reject, validated
from plantsolve.solvers.length_units import SIZES, request_unit

UnitsRule = Literal["file", "result", "quantities"]


@dataclass(frozen=True)
class FormRules:
    """How one kind's upload form joins its file: the request model and what the form's ``units`` is (see the
    module's rules); ``no_units`` says why a kind without units takes none (the refusal's words)."""

    request_model: type[BaseModel]
    units: UnitsRule | None
    no_units: str = "this kind's request has no units"

    @property
    def options_model(self) -> type[BaseModel]:
        return self.request_model.model_fields["options"].annotation


@dataclass(frozen=True)
class Form:
    """The form's options read once: ``units`` (a canonical symbol; perfmap's mapping as sent; None when not
    given), ``options`` by request option as sent, ``at``: where the form holds each, and ``read``: the options
    validated (every option a form leaves out at its default)."""

    read: BaseModel
    units: Any = None
    options: dict[str, Any] = field(default_factory=dict)
    at: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def named(self, error: FieldError) -> FieldError | None:
        """``error`` of the request's validation named where the form holds its value, or None when the value
        there is not the form's."""
        loc = error.loc
        if len(loc) > 1 and loc[0] == "options" and loc[1] in self.at:
            return replace(error, loc=(*self.at[loc[1]], *loc[2:]))
        return None


def read_form(options: Any, rules: FormRules) -> Form:
    """The upload form's ``options`` part checked on its own: each bad value named where the form holds it."""
    if options is None:
        return Form(read=rules.options_model())
    if not isinstance(options, dict):
        raise reject("the form's options must be a JSON object", ("options",), "dict_type")
    flat = dict(options)
    units = flat.pop("units", None)
    nested = flat.pop("options", None)
    if nested is not None and not isinstance(nested, dict):
        raise reject("options.options must be an object of the request's options", ("options", "options"), "dict_type")
    errors: list[FieldError] = []
    at = {name: ("options", name) for name in flat}
    for name, value in (nested or {}).items():
        if name in flat and value != flat[name]:
            errors.append(FieldError(("options", "options", name), (
                f"the form gives {name} twice: {flat[name]!r} at options.{name} and {value!r} at "
                f"options.options.{name}; give it once"), "value_error"))
        at.setdefault(name, ("options", "options", name))
    given = {**(nested or {}), **flat}
    if units is not None:
        if rules.units is None:
            errors.append(FieldError(("options", "units"), rules.no_units, "extra_forbidden"))
        elif rules.units != "quantities":
            units, unit_errors = _read_units(rules.request_model, units)
            errors += unit_errors
    try:
        read = validated(rules.options_model, given, ())
    except InputRejected as rejected:
        errors += [_said_as_unit(replace(e, loc=(*at[e.loc[0]], *e.loc[1:])), rules.options_model, given)
                   if e.loc and e.loc[0] in at else replace(e, loc=("options", *e.loc)) for e in rejected.errors]
        read = None
    if errors:
        raise InputRejected(errors)
    return Form(read=read, units=units, options=given, at=at)


@cache
def _units_model(request_model: type[BaseModel]) -> type[BaseModel]:
    """The request's ``units`` field as a model of its own (same type, same spellings read)."""
    units = request_model.model_fields["units"]
    return create_model(f"{request_model.__name__}Units", units=(units.annotation, units))


def _read_units(request_model: type[BaseModel], given: Any) -> tuple[Any, list[FieldError]]:
    """(the canonical unit ``given`` spells, the errors naming ``options.units`` when it spells none)."""
    model = _units_model(request_model)
    try:
        return validated(model, {"units": given}, ("options",)).units, []
    except InputRejected as rejected:
        return given, [_said_as_unit(e, model, {"units": given}) for e in rejected.errors]


_FORM_PARTS = (("options",), ("options", "options"))
"""Where the form's options part holds an option in a refusal's path: flat, or nested as a request holds them."""


def _said_as_unit(error: FieldError, model: type[BaseModel], given: dict,
                  within: tuple[tuple, ...] = _FORM_PARTS) -> FieldError:
    """``error`` of a unit field's enum refusing a word as :func:`request_unit` says it: the units with their names
    (``unknown unit 'yd'; one of mm, cm, m, in, ft (or their names: ...)``), not the bare list of symbols. The
    schema's own words for a word it knows (micrometres where a request's unit cannot be) stay. ``within``: the paths
    under which ``model``'s own fields lie in a refusal (the form's options part; ``((),)`` for the request's)."""
    name = error.loc[-1]  # a field of ``model`` itself only when directly under ``within``, not one nested deeper
    field_info = model.model_fields.get(name) if isinstance(name, str) and error.loc[:-1] in within else None
    word = given.get(name)
    among = _unit_names(field_info.annotation) if field_info is not None else ()
    if not among or not isinstance(word, str) or error.type != "literal_error" or \
            not error.msg.startswith("Input should be"):
        return error
    try:
        request_unit(word, among)
    except ValueError as said:
        return replace(error, msg=str(said))
    return error


def _unit_names(annotation: Any) -> tuple[str, ...]:
    """The unit names a field's type allows when it is a length unit's enum (``Units``, ``FileUnits``), else ()."""
    names = [arg for arg in get_args(annotation) if isinstance(arg, str)]
    if names and get_origin(annotation) is Literal:
        return tuple(names) if set(names) <= set(SIZES) else ()
    return next((found for arg in get_args(annotation) if (found := _unit_names(arg))), ())


def file_options(body: dict) -> dict:
    """The options an uploaded request file states itself: none when it has no ``options``; anything but an object
    (``[]``, ``""``, ``0``, ``null``) is refused naming ``file.options``, as validating the file alone would (laid
    under the form's, it was taken for no options at all)."""
    own = body.get("options", {})
    if not isinstance(own, dict):
        raise reject("options must be an object", ("file", "options"), "dict_type")
    return own


def merged(body: dict, form: Form, rules: FormRules) -> dict:
    """``body`` (a request file's, or the request a reader made of its file) with the form's options and units laid
    in; an option or unit the two give differently is refused naming both places."""
    own = file_options(body)
    if not form.options and form.units is None:
        return body
    errors: list[FieldError] = []
    out = dict(body)
    if form.options:
        shared = [name for name in form.options if name in own]
        if shared:
            read_own = validated(rules.options_model, own, ("file", "options"))
            errors += [FieldError(form.at[name], (
                f"{'.'.join(form.at[name])} {form.options[name]!r} contradicts the file's file.options.{name} "
                f"{own[name]!r}: give it in one place (or the same in both)"), "value_error")
                for name in shared if getattr(form.read, name) != getattr(read_own, name)]
        out["options"] = {**own, **form.options}
    if form.units is not None and rules.units == "file":
        stated = body.get("units")
        if stated is None:
            out["units"] = form.units
        else:
            own_unit, unreadable = _read_units(rules.request_model, stated)
            if not unreadable and own_unit != form.units:
                errors.append(FieldError(("options", "units"), (
                    f"options.units {form.units!r} contradicts the file's file.units {stated!r}: the file's numbers are "
                    "in its own units; say which is right (leave options.units out to use the file's, or correct the "
                    "file)"), "value_error"))
    if errors:
        raise InputRejected(errors)
    return out


def form_beside(body: dict, options: Any, rules: FormRules) -> Form:
    """The form's ``options`` read beside the request file ``body``: a bad value of the form's and one of the file's
    own options are named together (the file's first), not one after the other is mended."""
    errors: list[FieldError] = []
    try:
        form = read_form(options, rules)
    except InputRejected as rejected:
        errors += rejected.errors
    try:
        own = file_options(body)
        if errors:
            validated(rules.options_model, own, ("file", "options"))
    except InputRejected as rejected:
        errors[:0] = rejected.errors
    if errors:
        raise InputRejected(errors)
    return form


def request_of_file(body: dict, options: Any, rules: FormRules) -> Any:
    """The request of an uploaded request file ``body`` with the form's ``options`` joined to it
    (:func:`form_beside`, :func:`merged`, :func:`validated_request`)."""
    form = form_beside(body, options, rules)
    return validated_request(rules, merged(body, form, rules), form)


def in_file(error: FieldError) -> FieldError:
    """A request file's field named by its path in the file."""
    return replace(error, loc=("file", *error.loc))


def validated_request(rules: FormRules, body: dict, form: Form,
                      elsewhere: Callable[[FieldError], FieldError] = in_file) -> Any:
    """``body`` validated as the kind's request; each bad value named where the form holds it when it is the form's,
    else by ``elsewhere`` (a request file's path, by default)."""
    try:
        return validated(rules.request_model, body, ())
    except InputRejected as rejected:
        raise InputRejected([form.named(e) or elsewhere(_said_as_unit(e, rules.request_model, body, ((),)))
                             for e in rejected.errors]) from None
