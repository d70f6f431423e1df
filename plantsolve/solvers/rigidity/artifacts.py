"""The body–joint graph coloured by rigid cluster (PNG) and a CSV of bodies with their cluster."""

from __future__ import annotations

import csv
import io

import networkx as nx
from matplotlib import colormaps
from matplotlib.figure import Figure  # no pyplot: no global figure state
from matplotlib.lines import Line2D
from matplotlib.transforms import ScaledTranslation

from plantsolve.schemas.rigidity import RigidityRequest, RigidityResult
from plantsolve.solvers.base import Artifact, Solved
from plantsolve.solvers.plots import figure_artifact

MAX_NODES_DRAWN = 3000
MAX_COLOURED = 18  # the largest clusters get their own colour; the rest share light grey (counted in the legend)
PALETTE = [k for k in range(20) if k not in (14, 15)]  # tab20 without its greys


def graph_figure(request: RigidityRequest, result: RigidityResult) -> Figure:
    graph = nx.MultiGraph()
    cluster_of = {}
    order = sorted(range(len(result.clusters)), key=lambda k: (-len(result.clusters[k]), k))
    rank = {k: r for r, k in enumerate(order)}
    for k, members in enumerate(result.clusters):
        for b in members:
            cluster_of[b] = rank[k]
    nodes = list(cluster_of)[:MAX_NODES_DRAWN]
    graph.add_nodes_from(nodes)
    for j in result.joints:
        a, b = j.bodies
        if a in graph and b in graph:
            graph.add_edge(a, b, moves=j.moves, type=j.type)
    fig = Figure(figsize=(8.5, 6.5), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    pos = nx.spring_layout(graph, seed=1) if graph.number_of_nodes() else {}
    cmap = colormaps["tab20"]

    def colour(r):
        return cmap(PALETTE[r]) if r < MAX_COLOURED else (0.82, 0.82, 0.82, 1.0)

    small = graph.number_of_nodes() <= 60
    for moves, style, label in ((True, "solid", "joint that moves"), (False, "dashed", "joint that does not move")):
        edges = [(a, b) for a, b, d in graph.edges(data=True) if d["moves"] == moves]
        if edges:
            nx.draw_networkx_edges(graph, pos, edgelist=edges, ax=ax, style=style, width=1.2, edge_color="#444444")
    nx.draw_networkx_nodes(graph, pos, ax=ax, node_size=260 if small else 30,
                           node_color=[colour(cluster_of[n]) for n in graph.nodes], edgecolors="#444444")
    if small:
        # beside the node, not inside it: a name in a 15 px disc had to be 6 pt (unreadable)
        number = {p.id: p.part for p in request.parts}
        labels = {n: f"{n} ({number[n]})" if n in number else n for n in graph.nodes}
        texts = nx.draw_networkx_labels(graph, pos, labels=labels, ax=ax, font_size=9, verticalalignment="bottom")
        for text in texts.values():
            text.set_bbox({"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "none", "alpha": 0.7})
            text.set_transform(ax.transData + ScaledTranslation(0, 9 / 72, fig.dpi_scale_trans))
    handles = [Line2D([], [], color=colour(r), marker="o", linestyle="", markersize=8,
                      label=f"cluster {r + 1} ({_count(len(result.clusters[k]))})")
               for r, k in enumerate(order[:MAX_COLOURED])]
    if len(order) > MAX_COLOURED:
        rest = sum(len(result.clusters[k]) for k in order[MAX_COLOURED:])
        handles.append(Line2D([], [], color=colour(MAX_COLOURED), marker="o", linestyle="", markersize=8,
                              label=f"{len(order) - MAX_COLOURED} more clusters ({_count(rest)})"))
    handles.append(Line2D([], [], color="#444444", linestyle="solid", label="joint that moves"))
    handles.append(Line2D([], [], color="#444444", linestyle="dashed", label="joint that does not move"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    # a spring layout's coordinates mean nothing: no axes, only the drawing (and room for the labels)
    ax.set_axis_off()
    ax.margins(0.12)
    shown = "" if len(cluster_of) <= MAX_NODES_DRAWN else f", first {MAX_NODES_DRAWN} of {len(cluster_of)} bodies drawn"
    ax.set_title(f"body–joint graph: dof {result.dof} (generic {result.generic_dof}), "
                 f"{len(result.clusters)} rigid clusters{shown}", fontsize=9)
    return fig


def _count(n: int) -> str:
    return f"{n} body" if n == 1 else f"{n} bodies"


def _table(result: RigidityResult) -> bytes:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["body", "cluster", "superbrick"])
    superbrick = {b: k + 1 for k, s in enumerate(result.superbricks) for b in s}
    for k, members in enumerate(result.clusters):
        for b in members:
            writer.writerow([b, k + 1, superbrick.get(b, "")])
    return out.getvalue().encode()


def figures(request: RigidityRequest, result: RigidityResult) -> dict[str, Figure]:
    """Every plot by artifact stem."""
    return {"graph": graph_figure(request, result)}


def render_artifacts(request: RigidityRequest, solved: Solved) -> list[Artifact]:
    return [*(figure_artifact(f"{stem}.png", fig, dpi=100) for stem, fig in figures(request, solved.result).items()),
            Artifact("clusters.csv", "text/csv", _table(solved.result))]
