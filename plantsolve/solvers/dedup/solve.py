"""The dedup pipeline: read → world geometry → grouping → matching → sharing → post-pass → write →
proof (the written file read back). Phases as in the paper's Fig. 4, timed like its Table 2."""

from __future__ import annotations

import time
from collections import Counter

import ifcopenshell
import ifcopenshell.util.unit

from plantsolve.schemas.common import Diagnostic, Report
from plantsolve.schemas.dedup import DedupClass, DedupResult, Verification
from plantsolve.solvers.base import Progress, Solved, no_progress, reject
from plantsolve.solvers.dedup import compaction, ifcio, postpass, proof, sharing, skeleton
from plantsolve.solvers.dedup.explicit import ExplicitReader
from plantsolve.solvers.dedup.far_products import left_out_by_placement, placement_outliers
from plantsolve.solvers.dedup.grouping import build_classes, make_candidate, pool_transforms
from plantsolve.solvers.dedup.pipe_sizes import judge_pipe_diameters
from plantsolve.solvers.dedup.placements import (repeated_global_ids, why_nothing_placed, why_unprocessed,
                                                 world_coordinate_problem, world_refusal)
from plantsolve.solvers.dedup.source import IfcSource
from plantsolve.solvers.dedup.tolerance import from_precision, judge, judge_product_size, model_sizes, product_boxes
from plantsolve.solvers.dedup.typical_sizes import judge_typical_sizes
from plantsolve.solvers.dedup.worldgeom import DEPENDS, world_points
from plantsolve.solvers.ifc_units import named_unit_warnings, project_length_scale
from plantsolve.solvers.length_units import METRES, unit_of_size

DEFAULT_PRECISION_M = 1e-5
MAX_LISTED = 200


def resolve_mode(requested: str, schema: str) -> str:
    if requested == "auto":
        return "mapped_item" if schema == "IFC2X3" else "product_shape"
    return requested


def model_precision(model: ifcopenshell.file) -> float | None:
    """The Model context's Precision (file units), when it states one (whatever its value: judged by the solve)."""
    values = [float(c.Precision) for c in model.by_type("IfcGeometricRepresentationContext")
              if not c.is_a("IfcGeometricRepresentationSubContext") and c.Precision is not None]
    return max(values) if values else None


def length_unit_name(model: ifcopenshell.file) -> str:
    unit = ifcopenshell.util.unit.get_project_unit(model, "LENGTHUNIT")
    if unit is None:
        return "METRE"
    if unit.is_a("IfcSIUnit"):
        return f"{unit.Prefix or ''}{unit.Name}"
    return str(getattr(unit, "Name", unit.is_a()))


def length_unit_symbol(model: ifcopenshell.file, metres: float) -> str:
    """The project's length unit as a symbol pint reads ('mm', 'ft'), else its size in metres."""
    unit = ifcopenshell.util.unit.get_project_unit(model, "LENGTHUNIT")
    name = unit_of_size(metres)
    if name is not None:
        return name
    symbol = ifcopenshell.util.unit.get_unit_symbol(unit) if unit is not None else ""
    return symbol if symbol and symbol.isalpha() else f"{metres:g} m"


def _eligible(model, product, wanted: tuple[str, ...] | None, body) -> str | None:
    """Why ``product`` (whose body representation is ``body``) cannot be deduplicated, or None."""
    if wanted and not any(product.is_a(t) for t in wanted):
        return "entity not selected"
    if body is None:
        return "no single body representation"
    # the inverses are listed only when there is more than one (most products: their shape's and body's only user)
    if model.get_total_inverses(body) > 1 and model.get_total_inverses(body) > 1 + sum(
            1 for i in model.get_inverse(body) if i.is_a("IfcPresentationLayerAssignment")):
        return "body representation already shared"
    shape = product.Representation
    if model.get_total_inverses(shape) > 1 and sum(1 for i in model.get_inverse(shape) if i.is_a("IfcProduct")) > 1:
        return "product shape already shared"
    if product.ObjectPlacement is not None and not product.ObjectPlacement.is_a("IfcLocalPlacement"):
        return f"placement {product.ObjectPlacement.is_a()} is not an IfcLocalPlacement"
    return None


def _unmatched_entity_types(wanted: tuple[str, ...], products: list) -> list[Diagnostic]:
    """A warning naming the ``options.entity_types`` no product of the model is (nor a subtype of): a run that
    selects nothing shares nothing, and "0 products shared" would not say why."""
    missing = [t for t in wanted if not any(p.is_a(t) for p in products)]
    if not missing:
        return []
    return [Diagnostic(code="entity_types_unmatched", message=(
        f"No product of the model is an {', '.join(missing)} (options.entity_types): "
        f"{'nothing was' if len(missing) == len(wanted) else 'nothing of those was'} selected. The model's products "
        f"are {', '.join(sorted({p.is_a() for p in products})[:12])}."), details={"entity_types": missing})]


def described(classes: list) -> tuple[list[DedupClass], int]:
    """The result's classes (those of two or more members) and how many products share geometry."""
    out_classes = []
    shared = 0
    for cls in classes:
        if len(cls.members) < 2:
            continue
        shared += len(cls.members) - 1
        rep = cls.representative.product
        out_classes.append(DedupClass(
            representative=rep.GlobalId, members=[c.product.GlobalId for c, _ in cls.members],
            entity=rep.is_a(), object_type=getattr(rep, "ObjectType", None),
            transforms=[[float(v) for v in m.matrix.reshape(-1)] for _, m in cls.members],
            max_deviation=float(max(m.deviation for _, m in cls.members)),
            mirror=any(m.mirror for _, m in cls.members),
            scale=any(abs(m.scale - 1.0) > 1e-12 for _, m in cls.members)))
    return out_classes, shared


def _geometry(model: ifcopenshell.file, streamed: skeleton.Skeleton | None, products: list, progress: Progress):
    """The products' world points and face counts, and the reader that read them (its closures: the sharing's
    old geometry)."""
    reader = ExplicitReader(model, record_closures=True, streamed=streamed)
    points, triangles = world_points(model, products, progress=progress, span=(0.05, 0.35), reader=reader)
    return reader, points, triangles


def why_unverified(errors: list[str], differences: list[str], max_dev: float | None, tol: float) -> str:
    """What the verification found, in words: the first validation errors, the entities whose counts changed, or
    the largest deviation of a product from its input geometry."""
    if errors:
        return f"{len(errors)} validation error(s) the input did not have, first {errors[0]}"
    if differences:
        return f"the semantic entities changed ({'; '.join(differences[:3])})"
    if max_dev is not None and max_dev > tol:
        return f"a product moved {max_dev:g} from its input geometry, beyond the tolerance {tol:g}"
    return "the written file's semantic fingerprint differs from the input's"


def solve(source: IfcSource, progress: Progress = no_progress) -> Solved:
    """The deduplicated model's result and, when it passed its proof, the optimized file itself."""
    opts = source.options
    timings: dict[str, float] = {}
    cpu: dict[str, float] = {}  # the same phases in CPU seconds of this process (wall time varies with load)
    warnings: list[Diagnostic] = []
    clock, cpu_clock = time.perf_counter(), time.process_time()

    def lap(name: str) -> None:
        nonlocal clock, cpu_clock
        now, cpu_now = time.perf_counter(), time.process_time()
        timings[name] = round(now - clock, 4)
        cpu[name] = round(cpu_now - cpu_clock, 4)
        clock, cpu_clock = now, cpu_now

    progress(0.0, "reading the IFC file")
    with source.step_file() as (path, original_bytes):
        model, streamed = skeleton.open_model(path)
        index = streamed.index if streamed is not None else None  # the input's lines, for the proof's comparison
        lap("parse")
        schema = model.schema
        mode = resolve_mode(opts.sharing, schema)
        if mode == "product_shape" and schema == "IFC2X3":
            raise reject("'product_shape' needs IFC4 or later: in IFC2X3 an IfcProductDefinitionShape belongs to "
                         "exactly one product (ShapeOfProduct [1:1]); use 'mapped_item'", ("options", "sharing"))
        unit = project_length_scale(model, DEPENDS)
        warnings.extend(named_unit_warnings(model))
        unit_name = length_unit_name(model)
        symbol = length_unit_symbol(model, unit)
        assigned = ifcopenshell.util.unit.get_project_unit(model, "LENGTHUNIT") is not None
        source_units = {"file_unit": symbol, "ifc_name": unit_name, "metres_per_unit": unit, "basis":
                        "IfcUnitAssignment" if assigned else "none assigned: metres", "tolerance_unit": symbol}
        if not assigned:
            # every length of the file, the tolerance and the deviations are then read in metres, whatever the
            # authoring tool meant (millimetres, most often)
            warnings.append(Diagnostic(
                code="length_unit_not_assigned", message="The project assigns no length unit (no LENGTHUNIT in its "
                "IfcUnitAssignment): its lengths, the tolerance and the deviations are read in metres. If the model is "
                "in another unit, give options.tolerance in that unit's terms.",
                details={"quantity": "length unit", "assumed": "METRE"}))
        semantic_before = proof.semantic_fingerprint(model)
        products = [p for p in model.by_type("IfcProduct") if p.Representation is not None]
        if not products:
            raise reject("the file has no product with geometry (no IfcProduct has a Representation)")
        broken_world = world_coordinate_problem(model, path)
        if broken_world:  # the kernel places without it: the deviations would be claimed for meaningless points
            raise reject(world_refusal(broken_world))
        progress(0.05, "tessellating products in world coordinates")
        reader, points, triangles = _geometry(model, streamed, products, progress)
        if reader.needs_whole_model:  # the kernel tessellates a product with a streamed item: the whole file it is
            model, streamed = ifcio.open_path(str(path)), None
            products = [p for p in model.by_type("IfcProduct") if p.Representation is not None]
            reader, points, triangles = _geometry(model, None, products, progress)
        reader.forget_points()  # the world points are all the matching needs
        ids_before = compaction.instance_ids(model)
        if streamed is None:
            counts_before = proof.entity_counts(model, reader.closures, reader.closure_entities, ids_before)
            known = reader.closures
        else:  # the skeleton's instances, with the items' as the skeleton holds them, and the rest of the items'
            known = {**reader.closures, **streamed.parsed}
            counts = Counter(proof.entity_counts(model, known, {**reader.closure_entities,
                                                                **streamed.parsed_entities}, ids_before))
            counts_before = dict(sorted((counts + streamed.inner).items()))
        if not points:
            raise reject(why_nothing_placed(products, path))
        boxes = product_boxes(points.values())
        sizes = model_sizes(boxes)
        # the median product first; where it passes, doors, walls and storeys (CENTI over metres gives 2 cm doors),
        # then the pipes' outside diameters (a plant model has no doors; METRE numbers under FOOT give 35 mm pipes)
        warnings.extend(judge_product_size(sizes[0], symbol, unit) or judge_typical_sizes(
            products, points, (s.Elevation for s in model.by_type("IfcBuildingStorey")), symbol, unit, METRES)
            or judge_pipe_diameters(products, points, symbol, unit, METRES))
        if opts.tolerance is not None:
            tol, tolerance_from = float(opts.tolerance), "options.tolerance"
        else:
            tol, tolerance_from, precision_warnings = from_precision(model_precision(model), DEFAULT_PRECISION_M / unit,
                                                                     symbol, unit, sizes)
            warnings.extend(precision_warnings)
        source_units.update(tolerance=tol, tolerance_from=tolerance_from)
        warnings.extend(judge(tol, opts.tolerance is not None, symbol, unit, sizes))
        # by instance id (the written file keeps them): a GlobalId two products share would check only one
        before = {p.id(): points[p.id()] for p in products if p.id() in points}
        global_ids = {p.id(): p.GlobalId for p in products if p.id() in points}
        warnings.extend(repeated_global_ids(products))
        skipped = [{"global_id": p.GlobalId, "entity": p.is_a(), "reason": why_unprocessed(p)}
                   for p in products if p.id() not in points]
        lap("geometry")
        wanted = tuple(opts.entity_types) if opts.entity_types else None
        candidates = []
        for p in products:
            if p.id() not in points:
                continue
            body = reader.body(p)
            why = _eligible(model, p, wanted, body)
            if why is not None:
                if why != "entity not selected":
                    skipped.append({"global_id": p.GlobalId, "entity": p.is_a(), "reason": why})
                continue
            candidates.append(make_candidate(p, body, model, points[p.id()], triangles[p.id()]))
        if wanted:
            warnings.extend(_unmatched_entity_types(wanted, products))
        lap("grouping")
        classes = build_classes(candidates, tol, allow_mirror=opts.allow_mirror, allow_scale=opts.allow_scale,
                                progress=progress, span=(0.35, 0.55))
        pooled = pool_transforms(classes, tol)
        warnings.extend(left_out_by_placement(classes, tol, symbol))
        warnings.extend(placement_outliers(products, dict(zip(points, (boxes[0] + boxes[1]) / 2)), sizes[0], symbol,
                                           {c.product.GlobalId for cls in classes if len(cls.members) > 1
                                            for c, _ in cls.members}))
        del boxes
        lap("matching")
        if streamed is not None and not skeleton.rebuild_expected(streamed, reader.closures, classes):
            # little goes: removing it from the whole model is cheaper than writing what stays (compaction)
            model, known = ifcio.open_path(str(path)), {**reader.closures, **streamed.closures}
            for c in candidates:
                c.product = model.by_id(c.product.id())
            ids_before, streamed = compaction.instance_ids(model), None
        detached = sharing.Detached(model)
        # with the post-pass, a ring's members' equal new placements (product_shape) or operators (mapped_item)
        # are made once (the post-pass numbers them)
        made_once = {"product_shape": sharing.SharedPlacements, "mapped_item": sharing.SharedOperators}[mode]
        shared_once = made_once(model) if opts.postpass and made_once.applies(model) else None
        written = sharing.apply(model, classes, mode, progress=progress, span=(0.55, 0.65), detached=detached,
                                placements=reader.placements, shared=shared_once)
        out_classes, shared = described(classes)
        # the proof looks the written points up in the trees the matching built of the products' own
        shapes = {c.product.id(): c.shape for c in candidates}
        products_total = len(products)
        # the old model's instances are not used past this point: a rebuilt model replaces it
        ids_now = compaction.grown(model, ids_before, shared_once.skipped if shared_once else ())
        del ids_before
        if streamed is None:
            model = compaction.compacted(model, detached.roots, detached.styled_by, known=known, everything=ids_now)
        else:
            model = skeleton.compacted(model, streamed, detached.roots, detached.styled_by, known=known,
                                       everything=ids_now)
        del detached, reader, classes, candidates, products, points, triangles, p, ids_now, known, streamed
        lap("sharing")
        removed = {}
        if opts.postpass:
            removed = postpass.merge_identical(model, progress=progress, span=(0.65, 0.72), shared=shared_once)
        lap("postpass")
        progress(0.72, "writing the optimized file")
        optimized = ifcio.model_text(model)
        del model
        lap("write")
        progress(0.75, "verifying: reading the written file back")
        check = ifcio.read_back(optimized)
        again = {p.id(): p for p in check.by_type("IfcProduct")}
        back_products = [again[g] for g in before if g in again]
        after_points, _ = world_points(check, back_products, progress=progress, span=(0.75, 0.9),
                                       message="verifying geometry", unique=False)
        deviations = []
        missing = []
        for g, pts in before.items():
            prod = again.get(g)
            if prod is None or prod.GlobalId != global_ids[g] or prod.id() not in after_points:
                missing.append(global_ids[g])
                continue
            deviations.append(proof.deviation(pts, after_points[prod.id()], shapes.get(g), tol))
        semantic_after = proof.semantic_fingerprint(check)
        semantic_equal = semantic_after == semantic_before and not missing
        differences = proof.fingerprint_differences(semantic_before, semantic_after)
        if missing:
            differences.append(f"{len(missing)} product(s) without geometry after, e.g. {missing[0]}")
        progress(0.9, "validating the written file")
        verified, cpu_verified = time.perf_counter(), time.process_time()
        rules = proof.Rules(check.schema_identifier) if opts.express_rules else None
        judged = proof.verdict(check, optimized, path, rules, index)
        found, inherited_errors = judged.errors, judged.inherited
        counts_after = proof.entity_counts(check)
        del check, again, back_products, shapes, index
        errors = [f.text() for f in found]
        timings["validation"] = round(time.perf_counter() - verified, 4)
        cpu["validation"] = round(time.process_time() - cpu_verified, 4)
    lap("verification")
    max_dev = float(max(deviations)) if deviations else None
    verification = Verification(max_deviation=max_dev, products_checked=len(deviations),
                                semantic_counts_equal=semantic_equal, schema_valid=not errors,
                                validation_errors=errors[:proof.MAX_ERRORS_LISTED], express_rules=opts.express_rules,
                                errors_inherited=inherited_errors, instances_validated=judged.validated,
                                instances_changed=judged.changed)
    if inherited_errors:
        warnings.append(Diagnostic(code="input_invalid", message=f"The output has {len(errors)} validation error(s), "
                                   "all of them already in the input file", details={}))
    ok = semantic_equal and (not errors or inherited_errors) and (max_dev is None or max_dev <= tol)
    if skipped:
        warnings.append(Diagnostic(code="left_unchanged", message=f"{len(skipped)} product(s) were left as they "
                                   "were (their geometry could not be processed or is not deduplicable)",
                                   details={"products": skipped[:MAX_LISTED], "count": len(skipped)}))
    if written.get("fallback_to_mapped_item"):
        warnings.append(Diagnostic(code="mapped_item_fallback", message=f"{written['fallback_to_mapped_item']} "
                                   "member(s) could not share a product shape and were written as mapped items",
                                   details={}))
    if not ok:
        warnings.append(Diagnostic(code="verification_failed", message="The optimized file failed verification; "
                                   "it is not offered as an artifact", details={"max_deviation": max_dev,
                                                                                  "semantic_differences": differences}))
    summary = (f"{len(out_classes)} classes, {shared} of {products_total} products share geometry; "
               f"{len(optimized)} of {original_bytes} bytes ({mode})")
    details = {"source": {"format": "ifc", "schema": schema, "units": source_units}, "cpu_seconds": cpu,
               "written": written, "transforms_pooled": pooled, "postpass_removed": removed,
               "unprocessed": len(skipped)}
    if ok:
        report = Report(status="ok" if not warnings else "warning", message=summary, warnings=warnings,
                        details=details)
    else:
        # the job's deliverable is the optimized file: one that failed its proof is withheld, and a run with
        # nothing to deliver has failed, whatever it learnt (the verification's findings are in its details)
        report = Report(status="failed", stage="verification", warnings=warnings,
                        message=f"The optimized file failed verification and is withheld: "
                                f"{why_unverified([] if inherited_errors else errors, differences, max_dev, tol)} "
                                f"({summary}).",
                        details={**details, "verification": verification.model_dump(mode="json")})
    ratio = len(optimized) / original_bytes if original_bytes else 1.0
    result = DedupResult(
        schema=schema, length_unit=unit_name, units=symbol, metres_per_unit=unit, tolerance=tol, sharing=mode,
        products_total=products_total, products_shared=shared, classes=out_classes,
        original_bytes=original_bytes, optimized_bytes=len(optimized), optimization_ratio=ratio,
        optimization_rate=1.0 - ratio, entity_counts_before=counts_before, entity_counts_after=counts_after,
        verification=verification, timings=timings, report=report)
    progress(1.0, "done")
    return Solved(result, files={"optimized.ifc": optimized} if ok else {})
