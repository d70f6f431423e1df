"""A product the matching compares (its group key and world shape) and a class of congruent ones: what the
grouping builds, the representatives' choice re-roots and the sharing writes."""

from __future__ import annotations

from dataclasses import dataclass, field

from plantsolve.solvers.dedup.matching import Match, Shape


@dataclass
class Candidate:
    product: object  # the ifcopenshell entity_instance
    key: tuple
    shape: Shape


@dataclass
class CongruenceClass:
    representative: Candidate
    members: list[tuple[Candidate, Match]] = field(default_factory=list)  # the representative first (identity)
