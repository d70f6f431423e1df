"""Artifacts: the optimized IFC file (only when it passed verification), the classes as CSV, and a bar
chart of instances per entity type before/after (the paper's Fig. 10)."""

from __future__ import annotations

import csv
import io

import numpy as np
from matplotlib.figure import Figure  # no pyplot: no global figure state

from plantsolve.schemas.dedup import DedupResult
from plantsolve.solvers.base import Artifact, Solved
from plantsolve.solvers.dedup.source import IfcSource
from plantsolve.solvers.plots import figure_artifact, plain_decades

MAX_BARS = 24


def classes_csv(result: DedupResult) -> bytes:
    out = io.StringIO()
    writer = csv.writer(out)
    u = result.units
    # the transform's translation column is a length; the rotation (and scale) entries are pure numbers
    writer.writerow(["class", "representative", "member", "entity", "object_type", "mirror", "scale",
                     f"class_max_deviation [{u}]", *[f"t{r}{c} [{u}]" if c == 3 and r < 3 else f"t{r}{c} [1]"
                                                     for r in range(4) for c in range(4)]])
    for k, cls in enumerate(result.classes):
        for member, t in zip(cls.members, cls.transforms):
            writer.writerow([k + 1, cls.representative, member, cls.entity, cls.object_type or "", cls.mirror,
                             cls.scale, f"{cls.max_deviation:.6g}", *[repr(v) for v in t]])
    return out.getvalue().encode()


def counts_figure(result: DedupResult) -> Figure:
    # ties by name: a set's order changes from process to process (string hashes), and with it which of the tied
    # types made the first MAX_BARS and their order: the same result drew different charts
    names = sorted(set(result.entity_counts_before) | set(result.entity_counts_after),
                   key=lambda n: (-max(result.entity_counts_before.get(n, 0), result.entity_counts_after.get(n, 0)), n))
    names = names[:MAX_BARS]
    before = np.array([result.entity_counts_before.get(n, 0) for n in names], dtype=float)
    after = np.array([result.entity_counts_after.get(n, 0) for n in names], dtype=float)
    fig = Figure(figsize=(9, 0.32 * len(names) + 1.8))
    ax = fig.add_subplot(1, 1, 1)
    y = np.arange(len(names))
    ax.barh(y - 0.2, before, height=0.4, label=f"before ({result.original_bytes:,} bytes)", color="#c44e52")
    ax.barh(y + 0.2, after, height=0.4, label=f"after, {result.sharing} ({result.optimized_bytes:,} bytes)",
            color="#4c72b0")
    ax.set_yticks(y, names, fontsize=8)
    ax.invert_yaxis()
    ax.set_xscale("symlog", linthresh=1)
    plain_decades(ax.xaxis)
    ax.set_xlabel("instances in the file [count] (symmetric log scale)")
    ax.set_ylabel("IFC entity type")
    ax.set_title(f"Instances per entity type: {result.products_shared} of {result.products_total} products share "
                 f"geometry, rate {100 * result.optimization_rate:.1f} %", fontsize=9)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    return fig


def figures(source: IfcSource, result: DedupResult) -> dict[str, Figure]:
    """Every plot by artifact stem."""
    return {"entity_counts": counts_figure(result)}


def render_artifacts(source: IfcSource, solved: Solved) -> list[Artifact]:
    """The optimized file comes from the solve (``solved.files``), present only when it passed its proof."""
    result = solved.result
    artifacts = [Artifact("classes.csv", "text/csv", classes_csv(result)),
                 *(figure_artifact(f"{stem}.png", fig) for stem, fig in figures(source, result).items())]
    optimized = solved.files.get("optimized.ifc")
    if optimized is not None:
        artifacts.insert(0, Artifact("optimized.ifc", "application/x-step", optimized))
    return artifacts
