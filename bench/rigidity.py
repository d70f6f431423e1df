"""Benchmark of the rigidity solver on random LEGO-like models.

    python bench/rigidity.py            # 50, 200, 500 and 1,000 parts
    python bench/rigidity.py --quick    # 50 and 200 parts
    python bench/rigidity.py --catalogue [MODEL.ldr ...]   # parts known / unknown on real models
    python bench/rigidity.py --before main [--sizes 500]    # whole-job CPU s of git ref 'main' and of this code

Models come from ``synthetic.random_lego``: bricks and plates stacked on random earlier parts with
random overlaps (two or more studs rigid, one stud a hinge), hinge bricks 3937 + 3938 (both at one
position, as in the LDraw library's frames), and pairs of technic bricks joined by a pin 2780 turned
into their holes; no two parts overlap. Per size:

- parts, superbricks, flexible joints (between superbricks), largest biconnected block (superbricks);
- ``full``: the whole job (request checked, assembly built, exact pass, pebble game, collisions)
  — target 500 parts < 0.5 s;
- ``add`` / ``remove``: median time of one ``Assembly.add_part`` (connections found in the spatial
  hash, pebble game updated) while the model is built, and of one ``remove_part`` (20 % of the parts,
  re-added between removals) — target add < 5 ms; ``pebble rebuild``: the lazy rebuild of the generic
  pass that the next query after a removal pays;
- ``dock``: median time of a docking query for a 2 × 4 brick (10 poses) — target < 50 ms; ``dock
  cold``: the first query after a change, which also rebuilds the arrays of free connection points
  and of the parts' boxes;
- ``exact``: the exact pass alone (modular rank of each block's loop-closure matrix);
  ``float``: the same blocks with float SVD; ``dense SVD``: one float SVD of the whole body-twist
  constraint matrix (6 columns per part, every joint) — the baseline, with its dof, which must equal
  the exact dof (skipped above 1,500 columns with --quick, above 3,000 otherwise: it takes minutes beyond).

A second table: collisions of technic gearboxes (``synthetic.gearbox``: 15 parts each, two of them
placed twice) side by side, 1 to 50 (100 without --quick) boxes. ``one box``: each part's bounding box,
the collision shape before holes were cut, with pairs joined pin- or axle-in-hole left out as before
(the baseline, measured in the same run); ``holes``: the hole-cut boxes, with and without leaving
connected pairs out. Collisions found (2 per gearbox are real) and CPU seconds of the collision pass
(``time.process_time``, best of 3); peak RSS of the process after the row.

With ``--before REF``: only the whole job (``full``) per size, as CPU seconds (``time.process_time``), the
``plantsolve`` package of git ``REF`` (taken out of git into a temporary folder) and this checkout each in a child
process of their own, taken in turn for ``--rounds`` rounds (best of 3 solves per round, best round kept): the
baseline comes from the same run and the same load on the machine.

A third table: the parts catalogue on real LDraw models (the tests' official-parts fixture, the OMR
model 889 in ``tests/solvers/rigidity/omr/``, and every ``.ldr``/``.mpd`` given with ``--models``).
``before``: parts not in the 37 hand-coded parts (the catalogue before the generated one; measured in
the same run), ``after``: not in the hand-coded nor the generated catalogue; joints and collisions
the solver reports, CPU seconds of the whole solve (the first row also loads the data file, timed
alone on the ``load`` line).
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from plantsolve.schemas.rigidity import RigidityRequest  # noqa: E402
from plantsolve.solvers.base import StoredInput  # noqa: E402
from plantsolve.solvers.rigidity import generated  # noqa: E402
from plantsolve.solvers.rigidity.catalogue import CATALOGUE, normalise_number  # noqa: E402
from plantsolve.solvers.rigidity.upload import parse_upload  # noqa: E402
from plantsolve.solvers.rigidity.assembly import Assembly  # noqa: E402
from plantsolve.solvers.rigidity.collisions import Solid, find_collisions  # noqa: E402
from plantsolve.solvers.rigidity.docking import dock  # noqa: E402
from plantsolve.solvers.rigidity.mobility import Joint, analyse, dense_svd_dof  # noqa: E402
from plantsolve.solvers.rigidity.solve import solve  # noqa: E402
from plantsolve.solvers.rigidity.synthetic import gearbox, random_lego  # noqa: E402


def timed(fn, reps=3):
    best, out = float("inf"), None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def build(parts):
    assembly = Assembly()
    times = []
    for p in parts:
        t0 = time.perf_counter()
        assembly.add_part(p["id"], p["part"], p["position"], p["rotation"])
        times.append(time.perf_counter() - t0)
    return assembly, times


def removals(assembly, parts, rng):
    times = []
    for k in rng.choice(len(parts), max(1, len(parts) // 5), replace=False):
        p = parts[k]
        t0 = time.perf_counter()
        assembly.remove_part(p["id"])
        times.append(time.perf_counter() - t0)
        assembly.add_part(p["id"], p["part"], p["position"], p["rotation"])
    t0 = time.perf_counter()
    assembly.generic_dof  # noqa: B018  (the lazy rebuild of the pebble game)
    return times, time.perf_counter() - t0


def part_joints(assembly):
    ids = assembly.ids()
    index = {b: k for k, b in enumerate(ids)}
    return len(ids), [Joint(s.type, index[s.bodies[0]], index[s.bodies[1]], tuple(s.point), tuple(s.axis))
                      for s in assembly.all_joints()]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="50 and 200 parts only")
    args = parser.parse_args()
    sizes = (50, 200) if args.quick else (50, 200, 500, 1000)
    dense_limit = 1500 if args.quick else 3000
    rng = np.random.default_rng(0)
    head = (f"{'parts':>6} {'superbr.':>8} {'flexible':>8} {'block':>5} {'dof':>5} {'generic':>7} {'full s':>7} "
            f"{'add ms':>7} {'rm ms':>6} {'pebble s':>8} {'dock cold':>9} {'dock ms':>7} {'exact s':>7} {'float s':>7} "
            f"{'dense SVD s':>11} {'dense dof':>9}")
    print(head)
    print("-" * len(head))
    for n in sizes:
        parts = random_lego(n, seed=n)
        request = RigidityRequest.model_validate({"parts": parts})
        full, result = timed(lambda: solve(request).result, reps=3)
        assembly, adds = build(parts)
        rm, rebuild = removals(assembly, parts, rng)
        cold = timed(lambda: dock(assembly, "3001", 10), reps=1)[0]  # first query after a change
        dock_times = [timed(lambda: dock(assembly, "3001", 10), reps=1)[0] for _ in range(5)]
        exact_time, exact = timed(lambda: assembly.analyse(), reps=3)
        float_time, floating = timed(lambda: assembly.analyse(exact=False), reps=3)
        n_bodies, joints = part_joints(assembly)
        if 6 * n_bodies <= dense_limit:
            dense_time, dense = timed(lambda: dense_svd_dof(n_bodies, joints), reps=1)
            dense_cols = (f"{dense_time:>11.3f}", f"{dense:>9d}")
        else:
            dense_cols = (f"{'skipped':>11}", f"{'-':>9}")
        assert floating.mobility.dof == exact.mobility.dof == result.dof
        if dense_cols[1].strip() != "-":
            assert int(dense_cols[1]) == result.dof, (dense_cols, result.dof)
        print(f"{n:>6} {len(result.superbricks):>8} {len([j for j in result.joints if j.type != 'rigid']):>8} "
              f"{result.report.details['largest_block']:>5} {result.dof:>5} {result.generic_dof:>7} {full:>7.3f} "
              f"{1e3 * statistics.median(adds):>7.3f} {1e3 * statistics.median(rm):>6.3f} {rebuild:>8.3f} "
              f"{1e3 * cold:>9.1f} {1e3 * statistics.median(dock_times):>7.1f} {exact_time:>7.3f} {float_time:>7.3f} {dense_cols[0]} {dense_cols[1]}")
    print("\ntargets: 500 parts full < 0.5 s, add < 5 ms (median), dock < 50 ms; exact = float = dense dof checked")
    collisions_table(args.quick)


def cpu_timed(fn, reps=3):
    best, out = float("inf"), None
    for _ in range(reps):
        t0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t0)
    return best, out


def collisions_table(quick: bool) -> None:
    head = (f"{'boxes':>6} {'parts':>6} {'one box: found':>14} {'cpu s':>7} {'holes: found':>12} {'cpu s':>7} "
            f"{'holes, no pairs left out':>24} {'cpu s':>7} {'peak RSS MB':>11}")
    print("\n" + head)
    print("-" * len(head))
    for copies in (1, 10, 50) if quick else (1, 10, 50, 100):
        assembly, _ = build(gearbox(copies))
        ids, holes = assembly.solids()
        index = {b: k for k, b in enumerate(ids)}
        connected = {tuple(sorted((index[a], index[b]))) for a, b in assembly.inserted_pairs()}
        boxes = [Solid(center=p.rotation @ np.asarray(p.shape.box_center) + p.position,
                       size=np.asarray(p.shape.box_size, float), rotation=p.rotation) for p in assembly.parts.values()]
        one_t, one = cpu_timed(lambda: find_collisions(boxes, 0.01, connected))
        hole_t, hole = cpu_timed(lambda: find_collisions(holes, 0.01, connected))
        bare_t, bare = cpu_timed(lambda: find_collisions(holes, 0.01))
        assert len(hole) == len(bare) == 2 * copies
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"{copies:>6} {len(ids):>6} {len(one):>14} {one_t:>7.3f} {len(hole):>12} {hole_t:>7.3f} {len(bare):>24} "
              f"{bare_t:>7.3f} {rss:>11.0f}")
    print("two collisions per gearbox are real (a pin and a gear placed twice); the rest are rods in holes")


def catalogue_table(models: list[Path]) -> None:
    t0 = time.process_time()
    count = len(generated.numbers())
    print(f"\nload: {count} generated parts in {time.process_time() - t0:.3f} s CPU")
    head = (f"{'model':<34} {'parts':>6} {'unknown before':>15} {'unknown after':>14} {'joints':>7} "
            f"{'collisions':>10} {'solve s':>8}")
    print(head)
    print("-" * len(head))
    for path in models:
        request = parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), None)
        n = len(request.parts)
        before = sum(normalise_number(p.part) not in CATALOGUE for p in request.parts)
        t0 = time.process_time()
        result = solve(request).result
        took = time.process_time() - t0
        after = len(result.unknown_parts)
        print(f"{path.name[:34]:<34} {n:>6} {before:>6} ({100 * before / n:4.1f}%) {after:>5} ({100 * after / n:4.1f}%) "
              f"{len(result.joints):>7} {len(result.collisions):>10} {took:>8.3f}")


def full_cpu(sizes: list[int]) -> dict[int, float]:
    """CPU seconds of the whole job per size (best of 3), in this process."""
    out = {}
    for n in sizes:
        request = RigidityRequest.model_validate({"parts": random_lego(n, seed=n)})
        solve(request)  # the first solve also loads the catalogue's data and imports: not timed
        out[n] = cpu_timed(lambda request=request: solve(request), reps=3)[0]
    return out


def _child(folder: str | None, sizes: list[int]) -> dict[int, float]:
    """full_cpu in a child process: of the package in ``folder`` (a git ref taken out), or of this checkout."""
    boot = "import runpy, sys; sys.argv = sys.argv[1:]; runpy.run_path(sys.argv[0], run_name='__main__')"
    if folder is not None:  # the editable install's import hook would find this checkout's package first: drop it
        boot = ("import sys; sys.meta_path[:] = [f for f in sys.meta_path if '__editable__' not in repr(f)]; "
                f"sys.path.insert(0, {folder!r}); import plantsolve; " + boot)  # imported before this file's path
    out = subprocess.run([sys.executable, "-c", boot, __file__, "--full-cpu", *map(str, sizes)], check=True,
                         capture_output=True, text=True).stdout
    package, row = out.splitlines()[-2:]
    assert (folder is None) != package.startswith(folder or "//"), package  # the baseline runs the ref's package
    return {int(k): v for k, v in json.loads(row).items()}


def compare(ref: str, sizes: list[int], rounds: int) -> None:
    root = Path(__file__).resolve().parents[1]
    archive = subprocess.run(["git", "archive", "--format=tar", ref, "plantsolve"], cwd=root, check=True,
                             capture_output=True).stdout
    best_before = {n: float("inf") for n in sizes}
    best_after = dict(best_before)
    with tempfile.TemporaryDirectory() as folder:
        with tarfile.open(fileobj=BytesIO(archive)) as tar:
            tar.extractall(folder, filter="data")
        for _ in range(rounds):
            for n, t in _child(folder, sizes).items():
                best_before[n] = min(best_before[n], t)
            for n, t in _child(None, sizes).items():
                best_after[n] = min(best_after[n], t)
    print(f"whole job, CPU s (best of 3 solves x {rounds} rounds, taken in turn): {ref} -> this checkout")
    print(f"{'parts':>6} {ref[:12]:>12} {'now':>8} {'now/' + ref[:8]:>13}")
    for n in sizes:
        print(f"{n:>6} {best_before[n]:>12.3f} {best_after[n]:>8.3f} {best_after[n] / best_before[n]:>13.2f}")


if __name__ == "__main__":
    if "--full-cpu" in sys.argv:  # a child of --before
        import plantsolve
        print(plantsolve.__file__)
        print(json.dumps(full_cpu([int(a) for a in sys.argv[sys.argv.index("--full-cpu") + 1:]])))
    elif "--before" in sys.argv:
        extra = argparse.ArgumentParser(description="whole-job CPU s of a git ref and of this checkout, in turn")
        extra.add_argument("--before", required=True, help="git ref of the baseline")
        extra.add_argument("--sizes", type=int, nargs="+", default=[500], help="model sizes (parts)")
        extra.add_argument("--rounds", type=int, default=3, help="rounds of both children taken in turn")
        options = extra.parse_args()
        compare(options.before, options.sizes, options.rounds)
    elif "--catalogue" in sys.argv:
        here = Path(__file__).resolve().parents[1] / "tests" / "solvers" / "rigidity"
        extra = [Path(a) for a in sys.argv[sys.argv.index("--catalogue") + 1:]]
        catalogue_table([here / "official_parts.ldr", *sorted((here / "omr").glob("*.mpd")), *extra])
    else:
        main()
