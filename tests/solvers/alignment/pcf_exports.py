"""PCF files written the way real exporters write them, from exactly known pipe routes.

Each builder lays a route out exactly (pipes, elbows, 180 degree return bends, tees, flanges,
gaskets, valves, caps, olets), optionally disturbs items the way a model drifts (small rigid
motions of single items), and prints it in one exporter's style: its header records, its ids,
its quirks, its number of decimals. ``python tests/solvers/alignment/pcf_exports.py`` rewrites the
fixture files in ``data/`` (deterministic).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

DATA = Path(__file__).parent / "data"


@dataclass(eq=False)
class Item:
    keyword: str
    ends: list[np.ndarray]
    centre: np.ndarray | None = None
    branches: list[np.ndarray] = field(default_factory=list)
    bore: float = 150.0
    records: list[str] = field(default_factory=list)  # extra indented records, written as given
    end_types: tuple[str, str] = ("BW", "BW")

    def points(self) -> list[np.ndarray]:
        return self.ends + ([self.centre] if self.centre is not None else []) + self.branches

    def move(self, R: Rotation, t: np.ndarray) -> None:
        """A rigid drift of the item about its own centroid."""
        c = np.mean(self.points(), axis=0)
        f = lambda p: R.apply(p - c) + c + t
        self.ends = [f(p) for p in self.ends]
        self.branches = [f(p) for p in self.branches]
        if self.centre is not None:
            self.centre = f(self.centre)


class Route:
    """A cursor that lays items end to end along a direction (unit), turning in given planes."""

    def __init__(self, start, direction, bore=150.0):
        self.p = np.asarray(start, dtype=float)
        self.u = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
        self.bore = bore
        self.items: list[Item] = []

    def _add(self, item: Item) -> Item:
        self.items.append(item)
        return item

    def straight(self, keyword: str, length: float, **kw) -> Item:
        a, b = self.p.copy(), self.p + length * self.u
        self.p = b
        return self._add(Item(keyword, [a, b], bore=kw.pop("bore", self.bore), **kw))

    def gap(self, length: float) -> None:
        self.p = self.p + length * self.u

    def elbow(self, angle: float, towards, radius: float = 228.6, keyword: str = "ELBOW", **kw) -> Item:
        """Turn by angle (degrees) towards the direction ``towards`` (projected normal to the current one)."""
        w = np.asarray(towards, float) - np.dot(towards, self.u) * self.u
        w /= np.linalg.norm(w)
        th = np.radians(angle)
        arm = radius * np.tan(th / 2)
        cp = self.p + arm * self.u
        u2 = np.cos(th) * self.u + np.sin(th) * w
        a, b = self.p.copy(), cp + arm * u2
        self.p, self.u = b, u2
        return self._add(Item(keyword, [a, b], centre=cp, bore=self.bore, **kw))

    def return_bend(self, towards, radius: float = 228.6, centre_on_chord: bool = True, **kw) -> Item:
        """A 180 degree bend: the route comes back parallel, 2 radius to the side."""
        w = np.asarray(towards, float) - np.dot(towards, self.u) * self.u
        w /= np.linalg.norm(w)
        a, b = self.p.copy(), self.p + 2 * radius * w
        # E3D writes the arc centre (on the chord); other writers a point on the outer side of the arc
        centre = a + radius * w if centre_on_chord else a + radius * w + radius * self.u
        self.p, self.u = b, -self.u
        return self._add(Item("BEND", [a, b], centre=centre, bore=self.bore, **kw))

    def tee(self, branch_towards, half_run: float = 178.0, branch: float = 178.0, **kw) -> tuple[Item, "Route"]:
        w = np.asarray(branch_towards, float) - np.dot(branch_towards, self.u) * self.u
        w /= np.linalg.norm(w)
        a, cp = self.p.copy(), self.p + half_run * self.u
        b, br = cp + half_run * self.u, cp + branch * w
        self.p = b
        item = self._add(Item("TEE", [a, b], centre=cp, branches=[br], bore=self.bore, **kw))
        sub = Route(br, w, self.bore)
        sub.items = self.items  # one item list for the whole line
        return item, sub


def fmt(v: float, decimals: int) -> str:
    s = f"{v:.{decimals}f}"
    return s[1:] if s.startswith("-") and float(s) == 0.0 else s


def write(items: list[Item], header: list[str], decimals: int, ids, eol: str = "\n", indent: str = "    ",
          materials: list[str] = (), sep: str = " ") -> str:
    """Items as PCF lines: ``ids(k, item)`` gives each item's identification records."""
    out = list(header)
    f = lambda p: sep.join(fmt(x, decimals) for x in p)
    for k, it in enumerate(items):
        out.append(it.keyword)
        for n, e in enumerate(it.ends):
            tail = f"{sep}{fmt(it.bore, decimals)}" + (f"{sep}{it.end_types[n % 2]}" if it.end_types else "")
            out.append(f"{indent}END-POINT{sep}{f(e)}{tail}")
        if it.centre is not None:
            out.append(f"{indent}CENTRE-POINT{sep}{f(it.centre)}")
        for n, b in enumerate(it.branches, start=1):
            out.append(f"{indent}BRANCH{n}-POINT{sep}{f(b)}{sep}{fmt(it.bore, decimals)}")
        out.extend(indent + r for r in ids(k, it))
        out.extend(indent + r for r in it.records)
    out.extend(materials)
    return eol.join(out) + eol


def drift(items: list[Item], rng: np.random.Generator, keep: set[int], mm: float, deg: float) -> None:
    for k, it in enumerate(items):
        if k in keep:
            continue
        R = Rotation.from_rotvec(np.radians(deg) * rng.normal(size=3) / np.sqrt(3))
        it.move(R, mm * rng.normal(size=3) / np.sqrt(3))


def e3d_return_bends() -> str:
    """AVEVA E3D: plant coordinates, 2 decimals, UCI database references, COMPONENT-IDENTIFIER sequence,
    180 degree return bends (ANGLE 18000, CENTRE-POINT on the chord), a MISC-COMPONENT, an OLET written
    without CENTRE-POINT, items drifted by a few mm; the nozzle flange is the tie-in."""
    rng = np.random.default_rng(11)
    r = Route([1203000.0, -845000.0, 104500.0], [1, 0, 0])
    r.straight("FLANGE", 120.0, records=["SKEY FLWN"], end_types=("FL", "BW"))
    r.straight("PIPE", 2400.0)
    r.return_bend([0, 1, 0], records=["ANGLE 18000", "SKEY BEBW"])
    r.straight("PIPE", 2400.0)
    r.return_bend([0, 1, 0], records=["ANGLE 18000", "SKEY BEBW"])
    r.straight("PIPE", 1800.0)
    r.straight("MISC-COMPONENT", 250.0, records=["SKEY MCBW", "ITEM-DESCRIPTION SIGHT GLASS"])
    olet_pipe = r.straight("PIPE", 1600.0)
    r.elbow(90.0, [0, 0, 1], records=["ANGLE 9000", "SKEY ELBW"])
    r.straight("PIPE", 1500.0)
    r.return_bend([1, 0, 0], centre_on_chord=False, records=["ANGLE 18000", "SKEY BEBW"])
    r.straight("PIPE", 1500.0)
    r.straight("FLANGE", 120.0, records=["SKEY FLWN"], end_types=("BW", "FL"))
    a, b = olet_pipe.ends
    foot = a + 0.4 * (b - a)
    top = foot + np.array([0.0, 0.0, 84.0])
    olet = Item("OLET", [], branches=[top], bore=50.0, records=["SKEY WOBW"])
    vent = Item("PIPE", [top, top + [0.0, 0.0, 300.0]], bore=50.0)
    plug = Item("CAP", [top + [0.0, 0.0, 300.0]], bore=50.0, end_types=("BW",))
    at = r.items.index(olet_pipe) + 1
    r.items[at:at] = [olet, vent, plug]
    items = r.items
    drift(items, rng, keep={0, items.index(olet)}, mm=2.0, deg=0.05)
    header = ["ISOGEN-FILES ISOGEN.FLS", "UNITS-BORE MM", "UNITS-CO-ORDS MM", "UNITS-BOLT-LENGTH MM",
              "UNITS-BOLT-DIA MM", "UNITS-WEIGHT KGS", "PIPELINE-REFERENCE /150-HW-3101",
              "    PIPING-SPEC /A3B", "    DATE-DMY 24/11/2026"]
    nozzle = items[0].ends[0]
    header += ["END-CONNECTION-EQUIPMENT", f"    CO-ORDS {' '.join(fmt(x, 2) for x in nozzle)} 150.00",
               "    CONNECTION-REFERENCE /P-1101/N1"]
    ids = lambda k, it: [f"COMPONENT-IDENTIFIER {k + 1}", f"UCI =16384/{30001 + k}", "MATERIAL-IDENTIFIER 1"]
    materials = ["MATERIALS", "MATERIAL-IDENTIFIER 1", "    DESCRIPTION PIPE SMLS ASTM A106-B",
                 "ITEM-CODE AAFWNB150", "    DESCRIPTION FLANGE WN 150 CL300 RF"]
    return write(items, header, 2, ids, materials=materials)


def revit_caps_materials() -> str:
    """A Revit PCF exporter: CRLF, 4 decimals (feet converted to mm), DATE-MDY and ATTRIBUTE records,
    COMPONENT-IDENTIFIER = element id, UCI = unique id, CAPs written with two END-POINTs (one with the
    cap's length, one with both points at the pipe end), MATERIALS with MATERIAL-IDENTIFIER records;
    no exporter named, so the printed precision decides the tolerance."""
    rng = np.random.default_rng(5)
    r = Route([3048.0, 6096.0, 914.4], [0, 1, 0], bore=100.0)
    r.straight("FLANGE", 90.0, end_types=("FL", "BW"))
    r.straight("PIPE", 3000.0)
    tee, branch = r.tee([1, 0, 0], half_run=120.0, branch=120.0)
    r.straight("PIPE", 2000.0)
    r.straight("CAP", 60.0)
    branch.straight("PIPE", 1500.0)
    branch.elbow(90.0, [0, 0, 1], radius=152.4)
    branch.straight("PIPE", 800.0)
    cap = branch.straight("CAP", 0.0)
    items = r.items
    drift(items, rng, keep={0}, mm=1.5, deg=0.03)
    for it in items:  # a cap is one piece: after the drift its two points are still where they were
        if it is cap:
            it.ends = [it.ends[0], it.ends[0].copy()]
    header = ["ISOGEN-FILES ISOGEN.FLS", "UNITS-BORE MM", "UNITS-CO-ORDS MM", "UNITS-WEIGHT KGS",
              "UNITS-BOLT-DIA MM", "UNITS-BOLT-LENGTH MM", "PIPELINE-REFERENCE CW-2201",
              "DATE-MDY 11/24/2026", "PROJECT-IDENTIFIER 2026-114", "ATTRIBUTE1 Cooling water"]
    ids = lambda k, it: [f"COMPONENT-IDENTIFIER {412300 + 7 * k}", f"UCI 6f1c0a2e-1b7e-4a2e-9d0c-{k:012d}",
                         f"MATERIAL-IDENTIFIER {1 + (it.keyword != 'PIPE')}"]
    materials = ["MATERIALS", "MATERIAL-IDENTIFIER 1", "    DESCRIPTION Pipe Type: Carbon Steel - Sch 40",
                 "MATERIAL-IDENTIFIER 2", "    DESCRIPTION Fittings: Carbon Steel Butt Weld"]
    return write(items, header, 4, ids, eol="\r\n", materials=materials)


def tree_250m() -> str:
    """A 255 m tree (main line with four branches, sloped 1:200 for drainage) without tie-ins, exported
    exactly and rounded to 2 decimals; the fittings carry sub-millidegree angle noise. Nothing in it needs
    to move: every difference is the printing's."""
    rng = np.random.default_rng(3)
    slope = np.array([1.0, 0.0, -0.005])
    r = Route([1_120_000.0, 245_000.0, 12_500.0], slope, bore=200.0)
    r.straight("FLANGE", 130.0, end_types=("FL", "BW"))
    for k in range(4):
        r.straight("PIPE", 11_800.0)
        tee, sub = r.tee([0, 1 if k % 2 == 0 else -1, 0], half_run=200.0, branch=200.0)
        for _ in range(2):
            sub.straight("PIPE", 11_800.0)
            sub.straight("FLANGE", 130.0)
            sub.straight("GASKET", 3.0)
            sub.straight("FLANGE", 130.0)
        sub.straight("PIPE", 4_000.0)
        sub.elbow(90.0, [0, 0, -1], radius=304.8)
        sub.straight("PIPE", 2_000.0)
        sub.straight("FLANGE", 130.0, end_types=("BW", "FL"))
        r.straight("PIPE", 11_800.0)
    r.straight("PIPE", 10_000.0)
    r.straight("FLANGE", 130.0, end_types=("BW", "FL"))
    for it in r.items:
        if it.keyword in ("TEE", "ELBOW"):
            it.move(Rotation.from_rotvec(np.radians(8e-4) * rng.normal(size=3) / np.sqrt(3)), np.zeros(3))
    header = ["ISOGEN-FILES ISOGEN.FLS", "UNITS-BORE MM", "UNITS-CO-ORDS MM", "PIPELINE-REFERENCE 200-FW-0001"]
    return write(r.items, header, 2, lambda k, it: [f"COMPONENT-IDENTIFIER FW-{k + 1:04d}"])


def flange_gasket_gaps() -> str:
    """Flanged joints whose gaskets were exported without thickness (one point at a flange face) while the
    flange faces stay 3 mm apart, plus a valve between two such joints, and one real 2 mm gap in a pipe run
    that has to be closed. 3 decimals, TAB separated."""
    r = Route([0.0, 0.0, 1000.0], [1, 0, 0], bore=100.0)
    r.straight("FLANGE", 100.0, end_types=("FL", "BW"))
    pipe1 = r.straight("PIPE", 2000.0)
    r.elbow(90.0, [0, 1, 0], radius=152.4)
    r.straight("PIPE", 1500.0)
    r.straight("FLANGE", 100.0, end_types=("BW", "FL"))
    face = r.p.copy()
    r.gap(3.0)
    g1 = Item("GASKET", [face], bore=100.0, end_types=())
    r.items.append(g1)
    r.straight("VALVE", 300.0, end_types=("FL", "FL"), records=["SPINDLE-DIRECTION UP"])
    face = r.p.copy()
    r.gap(3.0)
    r.items.append(Item("GASKET", [face], bore=100.0, end_types=()))
    r.straight("FLANGE", 100.0, end_types=("FL", "BW"))
    r.straight("PIPE", 1200.0)
    # the real defect: the first pipe was shortened by 2 mm and shifted sideways by 1 mm
    a, b = pipe1.ends
    pipe1.ends = [a, b - np.array([2.0, -1.0, 0.0])]
    ids = lambda k, it: [f"ITEM-CODE {it.keyword[:3]}{k}"]
    header = ["ISOGEN-FILES\tISOGEN.FLS", "UNITS-BORE\tMM", "UNITS-CO-ORDS\tMM", "PIPELINE-REFERENCE\t100-CW-7"]
    return write(r.items, header, 3, ids, indent="\t", sep="\t")


def converter_handwheels() -> str:
    """A converter's PCF (3 decimals, COMPONENT-IDENTIFIER and SKEY records) that draws every valve's
    handwheel as two BEND items with ANGLE 18000 sharing both end points, CENTRE-POINT on the chord (a full
    ring 500 mm across, 600 mm above the valve on its spindle): not piping. Amid real piping: flanged valves,
    elbows, a real 180 degree return bend (CENTRE-POINT on its chord too), items drifted by about a mm."""
    rng = np.random.default_rng(21)
    r = Route([52_000.0, 18_000.0, 6_500.0], [1, 0, 0], bore=100.0)
    r.straight("FLANGE", 110.0, end_types=("FL", "BW"), records=["SKEY FLWN"])
    wheels = []
    for k in range(3):
        r.straight("PIPE", 1800.0 + 300.0 * k)
        r.straight("FLANGE", 110.0, end_types=("BW", "FL"), records=["SKEY FLWN"])
        valve = r.straight("VALVE", 280.0, end_types=("FL", "FL"), records=["SKEY VVFL", "SPINDLE-DIRECTION UP"])
        wheels.append(valve)
        r.straight("FLANGE", 110.0, end_types=("FL", "BW"), records=["SKEY FLWN"])
        if k == 0:
            r.straight("PIPE", 1200.0)
            r.elbow(90.0, [0, 1, 0], radius=152.4, records=["ANGLE 9000", "SKEY ELBW"])
        elif k == 1:
            r.straight("PIPE", 900.0)
            r.return_bend([0, 1, 0], radius=152.4, records=["ANGLE 18000", "SKEY BEBW"])
    r.straight("PIPE", 1500.0)
    r.straight("FLANGE", 110.0, end_types=("BW", "FL"), records=["SKEY FLWN"])
    items = r.items
    drift(items, rng, keep={0}, mm=1.0, deg=0.03)
    for valve in wheels:
        c = np.mean(valve.ends, axis=0) + np.array([0.0, 0.0, 600.0])
        u = (valve.ends[1] - valve.ends[0]) / np.linalg.norm(valve.ends[1] - valve.ends[0])
        p, q = c - 250.0 * u, c + 250.0 * u
        ring = [Item("BEND", [p, q], centre=c.copy(), bore=25.0, records=["ANGLE 18000", "SKEY HWHL"], end_types=()),
                Item("BEND", [q, p], centre=c.copy(), bore=25.0, records=["ANGLE 18000", "SKEY HWHL"], end_types=())]
        at = items.index(valve) + 1
        items[at:at] = ring
    header = ["ISOGEN-FILES ISOGEN.FLS", "UNITS-BORE MM", "UNITS-CO-ORDS MM", "UNITS-WEIGHT KGS",
              "PIPELINE-REFERENCE 100-CW-2040"]
    return write(items, header, 3, lambda k, it: [f"COMPONENT-IDENTIFIER {k + 1}"])


def network_300(decimals: int = 4, seed: int = 1) -> str:
    """About 300 items at plant coordinates: a main line of pipes, tees, flanged valves with gaskets and
    elbows turning every way, its branches ending in flanges, every item but the first drifted by about a
    mm (generated in the tests, not a fixture file)."""
    rng = np.random.default_rng(seed)
    r = Route([1_203_000.0, -845_000.0, 104_500.0], [1, 0, 0], bore=150.0)
    r.straight("FLANGE", 120.0, end_types=("FL", "BW"))
    turns = [[0, 1, 0], [0, 0, 1], [0, -1, 0], [0, 0, -1]]
    branches = []
    for k in range(30):
        r.straight("PIPE", 1500.0 + 100.0 * k)
        if k % 3 == 0:
            branches.append(r.tee(turns[(k + 1) % 4])[1])
        r.straight("PIPE", 800.0)
        r.straight("FLANGE", 120.0)
        r.straight("GASKET", 3.0)
        r.straight("VALVE", 300.0, end_types=("FL", "FL"))
        r.straight("GASKET", 3.0)
        r.straight("FLANGE", 120.0)
        r.elbow(90.0 if k % 4 else 45.0, turns[k % 4])
    for sub in branches:
        sub.straight("PIPE", 900.0)
        sub.elbow(90.0, [1, 0, 0])
        sub.straight("PIPE", 1200.0)
        sub.straight("FLANGE", 120.0, end_types=("BW", "FL"))
    drift(r.items, rng, keep={0}, mm=1.0, deg=0.05)
    header = ["ISOGEN-FILES ISOGEN.FLS", "UNITS-BORE MM", "UNITS-CO-ORDS MM", "PIPELINE-REFERENCE NET-300"]
    return write(r.items, header, decimals, lambda k, it: [f"COMPONENT-IDENTIFIER N{k + 1}"])


FIXTURES = {
    "converter_handwheels.pcf": converter_handwheels,
    "e3d_return_bends.pcf": e3d_return_bends,
    "revit_caps_materials.pcf": revit_caps_materials,
    "tree_250m.pcf": tree_250m,
    "flange_gasket_gaps.pcf": flange_gasket_gaps,
}

if __name__ == "__main__":
    for name, build in FIXTURES.items():
        (DATA / name).write_bytes(build().encode())
        print("wrote", DATA / name)
