"""Generated IFC models for tests, the example and the benchmark: the paper's case study (a tunnel
lining of rings × 8 prefabricated segment types along a curved alignment, every segment's mesh baked
into world coordinates far from the origin, Section "Results and discussion"), plus the awkward
variants a real exporter produces (shuffled vertex order, rotated face loops, mirrored and scaled
copies, nested placements, mapped items, extrusions).

Lengths in metres. The model is written with IfcOpenShell: ``ifcopenshell.api`` for the project
skeleton (units, contexts, spatial structure), plain entity creation for the thousands of meshes
(the API's per-call bookkeeping would dominate the benchmark's set-up time).
"""

from __future__ import annotations

import base64
import math
import random
import uuid
from dataclasses import dataclass, field

import numpy as np

import ifcopenshell
import ifcopenshell.api
import ifcopenshell.guid

WORLD_ORIGIN = np.array([1.0e6, 1.0e6, 30.0])  # map coordinates, as a georeferenced exporter writes them
SEGMENT_TYPES = ("A", "B", "C", "D", "E", "Counter Segment Left", "Counter Segment Right", "Keystone")
# angular span of each segment type in degrees (sums to 360 with the keystone)
SEGMENT_SPANS = (50.0, 50.0, 50.0, 50.0, 50.0, 47.5, 47.5, 15.0)


def segment_mesh(span_deg: float, *, inner: float = 2.9, outer: float = 3.2, width: float = 1.5,
                 taper_deg: float = 0.0, arcs: int = 6) -> tuple[np.ndarray, list[list[int]]]:
    """Vertices and quad/polygon faces of one ring segment (an annular sector of ``span_deg``),
    in a local frame: tunnel axis along +y, ring centre at the origin, the segment starting at angle 0.
    ``taper_deg`` narrows the far side (a keystone), which makes the shape chiral."""
    verts = []
    for side, y in ((0, 0.0), (1, width)):
        shrink = math.radians(taper_deg) * side
        angles = np.linspace(shrink, math.radians(span_deg) - shrink * 0.5, arcs + 1)
        for r in (inner, outer):
            for a in angles:
                verts.append((r * math.cos(a), y, r * math.sin(a)))
    n = arcs + 1
    idx = lambda side, ring, k: side * 2 * n + ring * n + k  # noqa: E731
    faces = []
    for k in range(arcs):
        faces.append([idx(0, 0, k), idx(0, 0, k + 1), idx(1, 0, k + 1), idx(1, 0, k)])  # inner surface
        faces.append([idx(0, 1, k), idx(1, 1, k), idx(1, 1, k + 1), idx(0, 1, k + 1)])  # outer surface
        faces.append([idx(0, 0, k), idx(0, 1, k), idx(0, 1, k + 1), idx(0, 0, k + 1)])  # front joint
        faces.append([idx(1, 0, k), idx(1, 0, k + 1), idx(1, 1, k + 1), idx(1, 1, k)])  # back joint
    faces.append([idx(0, 0, 0), idx(1, 0, 0), idx(1, 1, 0), idx(0, 1, 0)])  # radial joints
    faces.append([idx(0, 0, arcs), idx(0, 1, arcs), idx(1, 1, arcs), idx(1, 0, arcs)])
    return np.array(verts, dtype=float), faces


def rotation_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_y(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def ring_pose(ring: int, *, radius: float = 500.0, width: float = 1.5) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) of ring ``ring`` on a plan curve of ``radius`` (rings staggered by a roll of 22.5°)."""
    theta = ring * width / radius
    heading = rotation_z(theta)
    centre = WORLD_ORIGIN + np.array([radius * math.sin(theta), radius * (1.0 - math.cos(theta)), 0.0])
    roll = rotation_y(math.radians(22.5) * (ring % 2))
    return heading @ roll, centre


@dataclass
class Product:
    """One element to write: world-baked mesh or local geometry with a placement."""

    object_type: str
    entity: str = "IfcBuildingElementProxy"
    verts: np.ndarray | None = None  # world (or placement-local) coordinates
    faces: list[list[int]] | None = None
    placement: np.ndarray | None = None  # 4x4, relative to the parent placement
    parent: int | None = None  # index of the product whose placement this one's is relative to
    extrusion: tuple[float, float, float] | None = None  # (x dim, y dim, depth) of a rectangle extrusion
    mapped: bool = False  # write the mesh through an IfcRepresentationMap + IfcMappedItem
    container: int = 0  # index of the spatial element (ring) holding it
    name: str = ""
    style_rgb: tuple[float, float, float] | None = None
    text_only: bool = False  # a body the geometry kernel cannot process (an IfcTextLiteral)


@dataclass
class ModelSpec:
    schema: str = "IFC4"
    products: list[Product] = field(default_factory=list)
    containers: int = 1
    face_set: str = "auto"  # IFC4: IfcPolygonalFaceSet; IFC2X3 or "brep": IfcFacetedBrep; "surface_model":
    # IfcFaceBasedSurfaceModel (the paper's tunnel)
    precision: float = 1e-5


def shuffled(verts: np.ndarray, faces: list[list[int]], rng: np.random.Generator, *, rotate_loops: bool = True):
    """The same mesh with its vertex list permuted and every face loop starting at another vertex."""
    perm = rng.permutation(len(verts))
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(perm))
    new_verts = verts[perm]
    new_faces = []
    for f in faces:
        g = [int(inverse[i]) for i in f]
        if rotate_loops:
            k = int(rng.integers(len(g)))
            g = g[k:] + g[:k]
        new_faces.append(g)
    order = rng.permutation(len(new_faces))
    return new_verts, [new_faces[i] for i in order]


def tunnel_products(rings: int, *, shuffle: bool = False, seed: int = 0, arcs: int = 6) -> list[Product]:
    """``rings`` × 8 segments, meshes baked into world coordinates (the paper's world-coordinate model);
    ``arcs`` facets per segment arc set the mesh density (the paper's segments average ~29 kB of STEP
    text each: about ``arcs=40`` as a face-based surface model)."""
    rng = np.random.default_rng(seed)
    templates = [segment_mesh(span, taper_deg=4.0 if name == "Keystone" else 0.0, arcs=arcs)
                 for name, span in zip(SEGMENT_TYPES, SEGMENT_SPANS)]
    starts = np.cumsum((0.0,) + SEGMENT_SPANS[:-1])
    products = []
    for r in range(rings):
        R, t = ring_pose(r)
        for k, name in enumerate(SEGMENT_TYPES):
            verts, faces = templates[k]
            local = verts @ rotation_y(-math.radians(starts[k])).T
            world = local @ R.T + t
            if shuffle:
                world, faces = shuffled(world, faces, rng)
            products.append(Product(object_type=name, verts=world, faces=faces, container=r,
                                    name=f"Ring {r + 1} segment {name}"))
    return products


def tunnel_spec(rings: int, schema: str = "IFC4", face_set: str = "auto", **kw) -> ModelSpec:
    return ModelSpec(schema=schema, products=tunnel_products(rings, **kw), containers=rings, face_set=face_set)


def _placement(f, matrix: np.ndarray | None, rel):
    m = np.eye(4) if matrix is None else matrix
    axis = f.create_entity("IfcAxis2Placement3D",
                           f.create_entity("IfcCartesianPoint", [float(v) for v in m[:3, 3]]),
                           f.create_entity("IfcDirection", [float(v) for v in m[:3, 2]]),
                           f.create_entity("IfcDirection", [float(v) for v in m[:3, 0]]))
    return f.create_entity("IfcLocalPlacement", rel, axis)


def _mesh_item(f, schema: str, verts: np.ndarray, faces: list[list[int]], face_set: str):
    if schema != "IFC2X3" and face_set in ("auto", "polygonal"):
        points = f.create_entity("IfcCartesianPointList3D", [[float(c) for c in v] for v in verts])
        polys = [f.create_entity("IfcIndexedPolygonalFace", [i + 1 for i in face]) for face in faces]
        return f.create_entity("IfcPolygonalFaceSet", points, True, polys, None)
    pts = [f.create_entity("IfcCartesianPoint", [float(c) for c in v]) for v in verts]
    ifc_faces = [f.create_entity("IfcFace", [f.create_entity("IfcFaceOuterBound",
                                                            f.create_entity("IfcPolyLoop", [pts[i] for i in face]),
                                                            True)]) for face in faces]
    if face_set == "surface_model":
        return f.create_entity("IfcFaceBasedSurfaceModel", [f.create_entity("IfcConnectedFaceSet", ifc_faces)])
    return f.create_entity("IfcFacetedBrep", f.create_entity("IfcClosedShell", ifc_faces))


def _owner_history(f):
    person = f.create_entity("IfcPerson", None, "Generator", None)
    org = f.create_entity("IfcOrganization", None, "plantsolve", None)
    user = f.create_entity("IfcPersonAndOrganization", person, org)
    app = f.create_entity("IfcApplication", org, "1.0", "plantsolve dedup synthetic", "plantsolve")
    return f.create_entity("IfcOwnerHistory", user, app, None, "NOCHANGE", 1767225600, None, None, 1767225600)


def _style(f, schema: str, item, rgb: tuple[float, float, float]) -> None:
    colour = f.create_entity("IfcColourRgb", None, *rgb)
    rendering = f.create_entity("IfcSurfaceStyleRendering", colour, 0.0, None, None, None, None, None, None,
                                "NOTDEFINED")
    style = f.create_entity("IfcSurfaceStyle", None, "BOTH", [rendering])
    styles = [style] if schema != "IFC2X3" else [f.create_entity("IfcPresentationStyleAssignment", [style])]
    f.create_entity("IfcStyledItem", item, styles, None)


def build_model(spec: ModelSpec) -> ifcopenshell.file:
    """The IFC file of ``spec``: project, site, a tunnel building with one partial building per ring
    (with a property set ``ringNumber``, as in the paper), and the products."""
    f = ifcopenshell.api.run("project.create_file", version=spec.schema)
    owner = _owner_history(f)
    ids = random.Random(0)  # seeded GlobalIds: the same spec gives the same file

    def new_guid() -> str:
        return ifcopenshell.guid.compress(uuid.UUID(int=ids.getrandbits(128), version=4).hex)

    project = f.create_entity("IfcProject", new_guid(), owner, "Tunnel")
    length = ifcopenshell.api.run("unit.add_si_unit", f, unit_type="LENGTHUNIT")
    ifcopenshell.api.run("unit.assign_unit", f, units=[length])
    model = ifcopenshell.api.run("context.add_context", f, context_type="Model")
    model.Precision = spec.precision
    body = ifcopenshell.api.run("context.add_context", f, context_type="Model", context_identifier="Body",
                                target_view="MODEL_VIEW", parent=model)
    site = f.create_entity("IfcSite", new_guid(), owner, "Site", CompositionType="ELEMENT")
    tunnel = f.create_entity("IfcBuilding", new_guid(), owner, "Tunnel", CompositionType="ELEMENT")
    f.create_entity("IfcRelAggregates", new_guid(), owner, None, None, project, [site])
    f.create_entity("IfcRelAggregates", new_guid(), owner, None, None, site, [tunnel])
    site.ObjectPlacement = _placement(f, None, None)
    tunnel.ObjectPlacement = _placement(f, None, site.ObjectPlacement)
    rings = []
    for r in range(spec.containers):
        ring = f.create_entity("IfcBuilding", new_guid(), owner, f"Ring {r + 1}", None, None,
                               _placement(f, None, tunnel.ObjectPlacement), None, None, "PARTIAL")
        rings.append(ring)
    if rings:
        f.create_entity("IfcRelAggregates", new_guid(), owner, None, None, tunnel, rings)
        for r, ring in enumerate(rings):
            value = f.create_entity("IfcInteger", r + 1)
            prop = f.create_entity("IfcPropertySingleValue", "ringNumber", None, value, None)
            pset = f.create_entity("IfcPropertySet", new_guid(), owner, "Pset_Ring", None, [prop])
            f.create_entity("IfcRelDefinesByProperties", new_guid(), owner, None, None, [ring], pset)
    elements = []
    maps: dict[int, object] = {}
    for k, p in enumerate(spec.products):
        parent = elements[p.parent].ObjectPlacement if p.parent is not None else (
            rings[p.container].ObjectPlacement if rings else tunnel.ObjectPlacement)
        placement = _placement(f, p.placement, parent)
        if p.text_only:
            item = f.create_entity("IfcTextLiteral", p.name, f.create_entity(
                "IfcAxis2Placement3D", f.create_entity("IfcCartesianPoint", [0.0, 0.0, 0.0]), None, None), "LEFT")
            rep_type = "Annotation2D"
        elif p.extrusion is not None:
            xdim, ydim, depth = p.extrusion
            profile = f.create_entity("IfcRectangleProfileDef", "AREA", None,
                                      f.create_entity("IfcAxis2Placement2D",
                                                      f.create_entity("IfcCartesianPoint", [0.0, 0.0]), None),
                                      xdim, ydim)
            item = f.create_entity("IfcExtrudedAreaSolid", profile,
                                   f.create_entity("IfcAxis2Placement3D",
                                                   f.create_entity("IfcCartesianPoint", [0.0, 0.0, 0.0]), None, None),
                                   f.create_entity("IfcDirection", [0.0, 0.0, 1.0]), depth)
            rep_type = "SweptSolid"
        else:
            item = None
            rep_type = ("Tessellation" if spec.schema != "IFC2X3" and spec.face_set in ("auto", "polygonal") else
                        "SurfaceModel" if spec.face_set == "surface_model" else "Brep")
        if p.mapped:
            key = id(p.verts)
            if key not in maps:
                inner = _mesh_item(f, spec.schema, p.verts, p.faces, spec.face_set) if item is None else item
                if p.style_rgb is not None:  # as ArchiCAD and Revit write it: the style inside the map
                    _style(f, spec.schema, inner, p.style_rgb)
                shape = f.create_entity("IfcShapeRepresentation", body, "Body", rep_type, [inner])
                origin = f.create_entity("IfcAxis2Placement3D", f.create_entity("IfcCartesianPoint", [0.0, 0.0, 0.0]), None, None)
                maps[key] = f.create_entity("IfcRepresentationMap", origin, shape)
            op = f.create_entity("IfcCartesianTransformationOperator3D", None, None,
                                 f.create_entity("IfcCartesianPoint", [0.0, 0.0, 0.0]), None, None)
            item = f.create_entity("IfcMappedItem", maps[key], op)
            rep_type = "MappedRepresentation"
        elif item is None:
            item = _mesh_item(f, spec.schema, p.verts, p.faces, spec.face_set)
        if p.style_rgb is not None and not p.mapped:
            _style(f, spec.schema, item, p.style_rgb)
        shape = f.create_entity("IfcShapeRepresentation", body, "Body", rep_type, [item])
        product_shape = f.create_entity("IfcProductDefinitionShape", None, None, [shape])
        element = f.create_entity(p.entity, new_guid(), owner, p.name or f"{p.object_type} {k}", None,
                                  p.object_type, placement, product_shape, None)
        elements.append(element)
    by_container: dict[int, list] = {}
    for p, e in zip(spec.products, elements):
        by_container.setdefault(p.container, []).append(e)
    for c, members in by_container.items():
        holder = rings[c] if rings else tunnel
        f.create_entity("IfcRelContainedInSpatialStructure", new_guid(), owner, None, None, members, holder)
    return f


def tunnel_file(rings: int, schema: str = "IFC4", **kw) -> ifcopenshell.file:
    return build_model(tunnel_spec(rings, schema, **kw))


def example() -> dict:
    """A small valid request: a 2-ring world-coordinate tunnel (16 segments in 8 classes), base64 IFC."""
    model = tunnel_file(2, "IFC4")
    model.header.file_name.time_stamp = "2026-01-01T00:00:00"  # the same example whenever it is asked for
    text = model.to_string()
    return {"filename": "tunnel.ifc", "file": base64.b64encode(text.encode()).decode(),
            "options": {"tolerance": 0.0001, "sharing": "mapped_item", "postpass": True}}


def box_mesh(size: float = 1.0) -> tuple[np.ndarray, list[list[int]]]:
    """A cube (48 symmetries: every rotation of the octahedral group maps it onto itself)."""
    v = np.array([[x, y, z] for x in (0.0, size) for y in (0.0, size) for z in (0.0, size)])
    faces = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    return v, faces


def pose(rx: float, ry: float, rz: float, t) -> np.ndarray:
    """4×4 rigid transform: rotations about x, y, z (degrees, applied in that order), then ``t``."""
    from scipy.spatial.transform import Rotation  # noqa: PLC0415  (scipy only for the zoo)

    m = np.eye(4)
    m[:3, :3] = Rotation.from_euler("xyz", [rx, ry, rz], degrees=True).as_matrix()
    m[:3, 3] = t
    return m


def apply(m: np.ndarray, verts: np.ndarray) -> np.ndarray:
    return verts @ m[:3, :3].T + m[:3, 3]


ZOO_NAMES = ("chiral_a", "chiral_b_shuffled", "chiral_mirrored", "chiral_scaled_1pct", "cube_a", "cube_b",
             "chiral_nested_1", "chiral_nested_2", "mapped_a", "mapped_b", "column_a", "column_b", "column_red",
             "column_longer", "label_only")


def zoo_spec(schema: str = "IFC4", seed: int = 3) -> ModelSpec:
    """One model with every awkward case (products named as in ``ZOO_NAMES``), world coordinates ~1e6 m:

    - a chiral mesh (the keystone) baked at two poses, the second with shuffled vertices and rotated loops;
    - its mirror image and a copy scaled by 1 % (neither may join the rigid class);
    - a cube (a symmetric shape) at two poses;
    - two more copies of the chiral mesh in placement-local coordinates under nested placements (the
      first placed relative to ``cube_b``, the second relative to the first);
    - two products already using one IfcRepresentationMap through IfcMappedItem, its item styled inside the map;
    - three rectangular IfcExtrudedAreaSolid columns (one styled red, so not congruent in appearance)
      and a longer one;
    - a product whose body is only an IfcTextLiteral (the kernel makes no geometry of it: left as it was).
    """
    rng = np.random.default_rng(seed)
    chiral, chiral_faces = segment_mesh(15.0, taper_deg=4.0)
    cube, cube_faces = box_mesh(0.8)
    o = WORLD_ORIGIN
    p = []
    m_a = pose(10, 20, 30, o + [10.0, 5.0, 0.0])
    m_b = pose(-40, 5, 170, o + [-20.0, 40.0, 3.0])
    p.append(Product("chiral", verts=apply(m_a, chiral), faces=chiral_faces, name="chiral_a"))
    v, f = shuffled(apply(m_b, chiral), chiral_faces, rng)
    p.append(Product("chiral", verts=v, faces=f, name="chiral_b_shuffled"))
    mirror = np.diag([1.0, -1.0, 1.0, 1.0])
    p.append(Product("chiral", verts=apply(pose(0, 0, 60, o + [30.0, 0.0, 0.0]) @ mirror, chiral),
                     faces=[f[::-1] for f in chiral_faces], name="chiral_mirrored"))
    scale = np.diag([1.01, 1.01, 1.01, 1.0])
    p.append(Product("chiral", verts=apply(pose(0, 0, -60, o + [40.0, 0.0, 0.0]) @ scale, chiral),
                     faces=chiral_faces, name="chiral_scaled_1pct"))
    p.append(Product("cube", verts=apply(pose(0, 0, 0, o + [0.0, -10.0, 0.0]), cube), faces=cube_faces, name="cube_a"))
    p.append(Product("cube", verts=cube, faces=cube_faces, placement=pose(0, 0, 0, o + [5.0, -10.0, 0.0]),
                     name="cube_b"))
    # nested: local geometry under placements relative to cube_b's, then to the first nested one
    p.append(Product("chiral", verts=chiral, faces=chiral_faces, placement=pose(0, 90, 45, [2.0, 1.0, 0.5]),
                     parent=5, name="chiral_nested_1"))
    p.append(Product("chiral", verts=chiral, faces=chiral_faces, placement=pose(30, 0, -15, [0.0, 3.0, 0.0]),
                     parent=6, name="chiral_nested_2"))
    wood = (0.96, 0.75, 0.45)  # styled inside the shared map, as ArchiCAD exports its beams
    p.append(Product("mapped", verts=chiral, faces=chiral_faces, mapped=True, style_rgb=wood,
                     placement=pose(0, 0, 15, o + [60.0, 0.0, 0.0]), name="mapped_a"))
    p.append(Product("mapped", verts=chiral, faces=chiral_faces, mapped=True, style_rgb=wood,
                     placement=pose(0, 0, 195, o + [70.0, 0.0, 0.0]), name="mapped_b"))
    for k, (name, dims, rgb) in enumerate((("column_a", (0.4, 0.6, 3.0), None), ("column_b", (0.4, 0.6, 3.0), None),
                                           ("column_red", (0.4, 0.6, 3.0), (1.0, 0.0, 0.0)),
                                           ("column_longer", (0.4, 0.6, 3.5), None))):
        p.append(Product("column", entity="IfcColumn", extrusion=dims, style_rgb=rgb, name=name,
                         placement=pose(0, 0, 25 * k, o + [k * 3.0, 20.0, 0.0])))
    p.append(Product("label", text_only=True, placement=pose(0, 0, 0, o), name="label_only"))
    return ModelSpec(schema=schema, products=p, containers=1)

