"""``ifcopenshell.validate`` on a part of a model: its schema checks (types, cardinalities, inverses)
and EXPRESS rules (type and entity where-rules) on chosen instances, the global rules on the whole
file. The library validates a whole file and compiles the schema's rules anew each time (seconds, with
pytest's assertion rewriting that only serves to explain a violation); here the rules module is
imported as it is (bytecode cached by Python), and run by the library's own procedure
(``rule_executor.run``) restricted to the instances asked for. Every finding carries what tells it from another (the rule or attribute, the
entity, the message without instance ids) apart from where it was found."""

from __future__ import annotations

import collections
import importlib
import re
from collections.abc import Iterable
from dataclasses import dataclass

import ifcopenshell
import ifcopenshell.validate
from ifcopenshell.express import rule_executor

_ID = re.compile(r"#\d+")
_ADDRESS = re.compile(r"0x[0-9a-fA-F]+")
_ON_INSTANCE = re.compile(r"On instance:\n(?:    .*(?:\n|$))+")


def normalised(message: str) -> str:
    """A message without instance ids, memory addresses or the instance it was found on: what stays
    the same when the same error is found on another instance (normalised before any cut)."""
    return _ADDRESS.sub("0x", _ID.sub("#", _ON_INSTANCE.sub("", message))).strip()


@dataclass(frozen=True)
class Finding:
    rule: str  # 'IfcProduct.PlacementForShapeRepresentation', 'IfcRoot.GlobalId', a global rule, ''
    entity: str  # the entity of the instance it was found on ('' for the header and global rules)
    message: str  # normalised
    instance: str = ""  # the instance as written, for the report
    instance_id: int = 0  # 0: the header or a global rule

    @property
    def key(self) -> tuple[str, str, str]:
        return self.rule, self.entity, self.message

    def text(self, limit: int = 500) -> str:
        where = f"{self.instance}: " if self.instance else ""
        rule = f"[{self.rule}] " if self.rule else ""
        return f"{where}{rule}{self.message}"[:limit]


def _finding(statement: dict) -> Finding | None:
    if str(statement.get("level", "error")).lower() not in ("error", "critical"):
        return None
    inst = statement.get("instance")
    entity = inst.is_a() if isinstance(inst, ifcopenshell.entity_instance) else ""
    return Finding(str(statement.get("attribute") or ""), entity, normalised(str(statement.get("message", ""))),
                   str(inst) if inst is not None else "", inst.id() if entity else 0)


class _Part(ifcopenshell.file):
    """The model seen through a list of its instances: what ``ifcopenshell.validate.validate`` iterates
    over (it walks ``for inst in f``); everything else is the whole file's."""

    def __init__(self, whole: ifcopenshell.file, instances: list):
        self.__dict__.update(vars(whole))
        self._instances = instances

    def __iter__(self):
        return iter(self._instances)


def schema_findings(model: ifcopenshell.file, instances: list | None = None) -> list[Finding]:
    """The library's schema checks (header, applications, then per instance) on ``instances``
    (default: all)."""
    logger = ifcopenshell.validate.json_logger()
    target = model if instances is None else _Part(model, instances)
    ifcopenshell.validate.validate(target, logger, express_rules=False)
    return [f for f in map(_finding, logger.statements) if f is not None]


class Rules:
    """A schema's EXPRESS rules, compiled once: the global ones, the where-rules of each entity and
    of each defined type."""

    def __init__(self, schema_identifier: str):
        # imported, not compiled here: Python caches the module's bytecode and the module itself
        module = importlib.import_module(f"{rule_executor.__package__}.rules.{schema_identifier}")
        with open(module.__file__) as f:
            self.source = f.read()
        scope = vars(module)
        self.lines = self.source.split("\n")
        self.schema = ifcopenshell.ifcopenshell_wrapper.schema_by_name(schema_identifier)
        rules = [r for r in scope.values() if hasattr(r, "SCOPE")]
        self.global_rules = [r for r in rules if r.SCOPE == "file"]
        self._entity_rules: dict[str, list] = collections.defaultdict(list)
        for r in rules:
            if r.SCOPE == "entity":
                self._entity_rules[r.TYPE_NAME.lower()].append(r)
        subtypes = collections.defaultdict(list)
        for d in self.schema.declarations():
            if isinstance(d, ifcopenshell.ifcopenshell_wrapper.type_declaration) and isinstance(
                    d.declared_type(), ifcopenshell.ifcopenshell_wrapper.named_type):
                subtypes[d.declared_type().declared_type().name()].append(d.name())
        self.type_rules: dict[str, list] = collections.defaultdict(list)
        for r in rules:
            if r.SCOPE == "type":
                stack = [r.TYPE_NAME]
                while stack:
                    name = stack.pop()
                    self.type_rules[name].append(r)
                    stack += subtypes[name]
        self._by_entity: dict[str, list] = {}

    def entity_rules(self, entity: str) -> list:
        """The where-rules an instance of ``entity`` must meet (its own and its supertypes')."""
        if entity not in self._by_entity:
            out, decl = [], self.schema.declaration_by_name(entity)
            while decl is not None:
                out += self._entity_rules.get(decl.name().lower(), [])
                decl = decl.supertype()
            self._by_entity[entity] = out
        return self._by_entity[entity]

    def definition(self, error: Exception) -> str:
        """The violated rule's text, as ``rule_executor`` reports it."""
        line = error.__traceback__.tb_next.tb_lineno if error.__traceback__.tb_next else 0
        return rule_executor.reverse_compile(self.lines[line - 1]) if line else str(error)


class _Settings:
    """The rules are transpiled with EXPRESS '=' as Python '==' and read single inverses unpacked:
    the same switches ``rule_executor.run`` sets for their duration."""

    def __enter__(self):
        self.saved = (ifcopenshell.settings.unpack_non_aggregate_inverses,
                      ifcopenshell.settings.compare_instances_by_value)
        ifcopenshell.settings.unpack_non_aggregate_inverses = True
        ifcopenshell.settings.compare_instances_by_value = True

    def __exit__(self, *_):
        (ifcopenshell.settings.unpack_non_aggregate_inverses,
         ifcopenshell.settings.compare_instances_by_value) = self.saved


def global_rule_findings(model: ifcopenshell.file, rules: Rules) -> list[Finding]:
    out = []
    with _Settings():
        for rule in rules.global_rules:
            try:
                rule()(model)
            except RecursionError:
                continue
            except Exception as e:  # noqa: BLE001 (a rule that cannot be evaluated is violated, as in the library)
                out.append(Finding(rule.__name__, "", normalised(f"Rule {rule.__name__}:\n    {rules.definition(e)}")))
    return out


class _Types:
    """What the walk through attribute values asks of the schema, asked once per entity and per type: an entity's
    attributes that are not derived with their types, a type's where-rules, what it declares (an aggregation's
    element type), and whether a value's entity is a typed value. The schema's wrappers are kept here: a type
    is known by the identity of the wrapper that was asked."""

    def __init__(self, rules: Rules):
        self.rules = rules
        self._attributes: dict[str, list] = {}
        self._types: dict[int, tuple] = {}
        self._typed: dict[str, object] = {}

    def attributes(self, entity: str) -> list[tuple[int, object]]:
        got = self._attributes.get(entity)
        if got is None:
            decl = self.rules.schema.declaration_by_name(entity)
            got = self._attributes[entity] = [(i, attr.type_of_attribute()) for i, (attr, derived) in
                                              enumerate(zip(decl.all_attributes(), decl.derived())) if not derived]
        return got

    def of(self, ty) -> tuple[list, object | None]:
        """(the where-rules of ``ty``, the element type when ``ty`` declares an aggregation, else None)."""
        got = self._types.get(id(ty))
        if got is None:
            wrapper = ifcopenshell.ifcopenshell_wrapper
            named = ty
            while isinstance(named, wrapper.named_type):
                named = named.declared_type()
            name = None if isinstance(named, (wrapper.aggregation_type, wrapper.simple_type)) else named.name()
            declared = ty
            while isinstance(declared, (wrapper.named_type, wrapper.type_declaration)):
                declared = declared.declared_type()
            element = declared.type_of_element() if isinstance(declared, wrapper.aggregation_type) else None
            got = self._types[id(ty)] = (self.rules.type_rules.get(name, ()), element, ty)  # ty: kept, so is its id
        return got[0], got[1]

    def typed(self, entity: str):
        """The type declaration of a typed value's entity (``IfcLengthMeasure``), None for an entity."""
        if entity not in self._typed:
            decl = self.rules.schema.declaration_by_name(entity)
            self._typed[entity] = None if isinstance(decl, ifcopenshell.ifcopenshell_wrapper.entity) else decl
        return self._typed[entity]


def rule_findings(model: ifcopenshell.file, instances: Iterable, rules: Rules) -> list[Finding]:
    """The where-rules of the defined types in each instance's attribute values and of its entity."""
    out: list[Finding] = []
    types = _Types(rules)

    def run(found: Iterable, value, inst) -> None:
        """Each where-rule of ``found`` on ``value``, a violation recorded against ``inst``."""
        for rule in found:
            try:
                rule()(value)
            except RecursionError:
                pass
            except Exception as e:  # noqa: BLE001 (a rule that cannot be evaluated is violated, as in the library)
                name = f"{rule.TYPE_NAME}.{rule.RULE_NAME}"
                out.append(Finding(name, inst.is_a(), normalised(f"Rule {name}:\n    {rules.definition(e)}"),
                                   str(inst), inst.id()))

    def check(value, ty, inst) -> None:  # rule_executor.run's own walk through a value
        if value is None:
            return
        found, element = types.of(ty)
        if found:
            run(found, value, inst)
        if isinstance(value, (list, tuple)):
            if element is not None:
                for v in value:
                    check(v, element, inst)
        elif isinstance(value, ifcopenshell.entity_instance):
            decl = types.typed(value.is_a())
            if decl is not None:  # a typed value: its type's rules
                check(value[0], decl, inst)

    with _Settings():
        for inst in instances:
            try:
                values = list(inst)
            except RecursionError:
                continue
            except Exception as e:  # noqa: BLE001
                out.append(Finding("", inst.is_a(), normalised(str(e)), str(inst), inst.id()))
                continue
            name = inst.is_a()
            for i, ty in types.attributes(name):
                if i < len(values):
                    check(values[i], ty, inst)
            run(rules.entity_rules(name), inst, inst)
    return out
