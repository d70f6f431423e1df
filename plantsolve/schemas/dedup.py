"""Request and result models of the ``dedup`` solver (IFC duplicate-geometry removal).

Conventions
-----------
- Lengths (``tolerance``, deviations, transform translations) are in the IFC file's own length
  unit (the project's ``IfcUnitAssignment``; metres when it says metres): the option ``tolerance`` too, and the
  result's ``units`` names that unit (``report.details.source.units`` says where it came from).
- A transform is a 4 × 4 row-major matrix mapping the class representative's world geometry onto the
  member's: ``member = T · representative`` (homogeneous points as columns). Rigid unless the class
  says ``mirror`` or ``scale`` (only with ``allow_mirror`` / ``allow_scale``).
- ``optimization_ratio`` = optimized bytes / original bytes (the paper's Eq. 25),
  ``optimization_rate`` = 1 − ratio (Eq. 26).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, Field

from plantsolve.schemas.common import FiniteFloat, Flag, Number, Report, StrictModel, plain_numbers, unit

MAX_FILE_CHARS = 96 * 1024 * 1024
EntityName = Annotated[str, Field(min_length=3, max_length=100, pattern=r"^[A-Za-z][A-Za-z0-9_]*$")]


class DedupOptions(StrictModel):
    _plain_numbers = plain_numbers("tolerance")

    sharing: Literal["mapped_item", "product_shape", "auto"] = Field(
        default="mapped_item",
        description="How members reuse their class's geometry: 'mapped_item' (IfcRepresentationMap + IfcMappedItem, "
        "IFC2X3 and later), 'product_shape' (members share the representative's IfcProductDefinitionShape and "
        "carry the transform in their placement; IFC4 and later only), 'auto' (the smallest valid for the schema).")
    tolerance: Annotated[Number, Field(gt=0, le=1e3, allow_inf_nan=False)] | None = Field(
        default=None,
        description="Largest allowed distance between a member's points and its transformed representative, both "
        "ways, in the IFC file's own length unit (its IfcUnitAssignment: metres for most exports, millimetres for "
        "some; the result's units says which), not in the request's. Default: the model context's Precision (1e-5 m "
        "when absent). Refused beyond 0.1 m or from 5 % of the median product's size; warned above 5 mm or 0.5 % "
        "of it (implausible_tolerance).")
    allow_mirror: Flag = Field(default=False, description="Let mirrored copies join a class (written as IfcMappedItem).")
    allow_scale: Flag = Field(default=False, description="Let uniformly scaled copies join a class (IfcMappedItem).")
    postpass: Flag = Field(default=True, description="Merge identical non-rooted instances afterwards (points, "
                           "directions, placements, styles), respecting the schema's inverse cardinalities.")
    express_rules: Flag = Field(default=True, description="Validate the output against the schema's EXPRESS "
                                "rules too (a few seconds more); false checks types, cardinalities and inverses only.")
    entity_types: list[EntityName] | None = Field(
        default=None, max_length=200,
        description="Only products of these IFC entities (and their subtypes) are deduplicated, e.g. ['IfcWall'].")


class DedupRequest(StrictModel):
    """An IFC model (STEP physical file ``.ifc`` or zipped ``.ifczip``) and options. As JSON, ``file``
    holds the file base64-encoded; a multipart upload sends the file itself."""

    filename: Annotated[str, Field(min_length=1, max_length=255)] = Field(
        default="model.ifc", description="Name of the file; '.ifczip' means a zip archive holding one .ifc.")
    file: Annotated[str, Field(min_length=1, max_length=MAX_FILE_CHARS)] | None = Field(
        default=None, description="The IFC file, base64-encoded (JSON requests).")
    options: DedupOptions = Field(default_factory=DedupOptions)


class DedupClass(BaseModel):
    representative: str = Field(description="GlobalId of the product whose geometry the class shares.")
    members: list[str] = Field(description="GlobalIds of all products in the class, the representative first.")
    entity: str
    object_type: str | None = None
    transforms: list[list[FiniteFloat]] = Field(
        description="Per member (same order): 4x4 row-major matrix (16 numbers) taking the representative's world "
        "geometry onto the member's: the translation entries (indices 3, 7, 11) in units, the rest pure numbers.",
        json_schema_extra=unit("{units}"))
    max_deviation: FiniteFloat = Field(description="Largest two-way Hausdorff distance of a member (units).",
                                       json_schema_extra=unit("{units}"))
    mirror: bool = False
    scale: bool = False


class Verification(BaseModel):
    max_deviation: FiniteFloat | None = Field(
        description="Largest distance (units) between a product's world geometry before and after, read "
        "back from the written file (two-way Hausdorff per product).", json_schema_extra=unit("{units}"))
    products_checked: int
    semantic_counts_equal: bool = Field(description="Rooted instances per entity (products, property sets, "
                                        "spatial elements, relationships), GlobalIds, property values and each "
                                        "product's styles unchanged.")
    schema_valid: bool = Field(description="No error of ifcopenshell.validate in what the optimization wrote, "
                               "changed or re-referenced and the instances referring to those (two levels up), nor in "
                               "the schema's global rules. The rest of the file is the input's, instance for instance, "
                               "with whatever errors the input had there (not checked again).")
    validation_errors: list[str] = Field(default_factory=list, description="The errors found (at most 50), each "
                                         "'instance: [rule or attribute] message'.")
    express_rules: bool = Field(default=True, description="Whether EXPRESS where-rules were checked too.")
    instances_changed: int | None = Field(default=None, description="Instances of the output that are new, have "
                                          "other attribute values than in the input, or are referenced by other "
                                          "instances; null when the output was validated whole (under 1/25 of the "
                                          "input's size, checking all of it costs less than finding what changed).")
    instances_validated: int = Field(default=0, description="Instances of the output validated: the changed ones "
                                     "and what refers to them, or all of them.")
    errors_inherited: bool = Field(
        default=False, description="The output's validation errors are all errors the input file already had (then "
        "the optimized file is still offered; schema_valid stays false).")


class DedupResult(BaseModel):
    kind: Literal["dedup"] = Field(default="dedup", description="The solver kind of this result (what tells the "
                                   "results of GET /v1/jobs/{id}/result apart).")
    schema_: str = Field(alias="schema", description="IFC schema of the file, e.g. 'IFC4'.")
    length_unit: str = Field(description="The file's length unit as IFC names it (e.g. 'METRE', 'MILLIMETRE', 'FOOT').")
    units: str = Field(description="The file's length unit as a symbol ('m', 'mm', 'ft', …): the unit of "
                       "tolerance, every deviation and every transform's translation.")
    metres_per_unit: FiniteFloat = Field(description="Metres in one of units (the project's unit scale).",
                                         json_schema_extra=unit("m"))
    tolerance: FiniteFloat = Field(description="The tolerance used (units): options.tolerance, else the model "
                                   "context's Precision.", json_schema_extra=unit("{units}"))
    sharing: Literal["mapped_item", "product_shape"] = Field(description="The sharing mode used.")
    products_total: int
    products_shared: int = Field(description="Products now using another product's geometry (class members "
                                 "other than the representative).")
    classes: list[DedupClass] = Field(description="Congruence classes with at least two members.")
    original_bytes: int = Field(description="Size of the input's STEP text (of the .ifc inside an .ifczip).")
    optimized_bytes: int = Field(description="Size of the optimized STEP text (optimized.ifc).")
    optimization_ratio: FiniteFloat = Field(description="optimized_bytes / original_bytes (Eq. 25).",
                                            json_schema_extra=unit("1"))
    optimization_rate: FiniteFloat = Field(description="1 - optimization_ratio (Eq. 26).", json_schema_extra=unit("1"))
    entity_counts_before: dict[str, int]
    entity_counts_after: dict[str, int]
    verification: Verification
    timings: dict[str, FiniteFloat] = Field(description="Wall seconds per phase.", json_schema_extra=unit("s"))
    report: Report = Field(default_factory=Report)

    model_config = {"populate_by_name": True}
