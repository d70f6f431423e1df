"""The body–joint graph coloured by rigid cluster (PNG) and a CSV of bodies with their cluster."""

from __future__ import annotations

import csv
import io

import networkx as nx
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure  # no pyplot: no global figure state
from matplotlib.lines import Line2D
from matplotlib.transforms import Bbox

from plantsolve.schemas.rigidity import RigidityRequest, RigidityResult
from plantsolve.solvers.base import Artifact, Solved
from plantsolve.solvers.plots import figure_artifact

MAX_NODES_DRAWN = 3000
SPACING = 3.0  # spring layout's optimal node distance, times 1/sqrt(nodes) (networkx's default is 1)
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
    # three times networkx's default spacing: room beside each node for its label
    pos = nx.spring_layout(graph, seed=1, k=SPACING / graph.number_of_nodes() ** 0.5) if graph.number_of_nodes() else {}
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
    title = ax.set_title(f"body–joint graph: dof {result.dof} (generic {result.generic_dof}), "
                         f"{len(result.clusters)} rigid clusters{shown}", fontsize=9)
    if small:
        number = {p.id: p.part for p in request.parts}
        labels = {n: f"{n} ({number[n]})" if n in number else n for n in graph.nodes}
        left_out = _place_labels(fig, ax, graph, pos, labels)
        if left_out:
            title.set_text(title.get_text() + f"; {left_out} label(s) left out (no free place)")
    return fig


LABEL_RINGS = (9.0, 18.0, 30.0, 44.0, 60.0)  # points from the node: where a label is tried, nearest first
LABEL_DIRECTIONS = ((0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (-1, 1), (1, -1), (-1, -1))
LEADER_FROM = 18.0  # points: a label this far from its node is joined to it by a thin line


def _place_labels(fig: Figure, ax, graph, pos: dict, labels: dict) -> int:
    """Each node's label beside it (not inside: a name in a 15 px disc had to be 6 pt), at the nearest of a
    few places around it that overlaps no label placed before it, no node, the title or the legend, and stays
    in the figure; a label with no such place is left out. Returns how many were left out. The layout is
    fixed first (constrained layout would move the axes after the labels were placed)."""
    renderer = FigureCanvasAgg(fig).get_renderer()  # text extents need a renderer; Agg's is the PNG's
    fig.draw_without_rendering()
    fig.set_layout_engine("none")
    page = fig.bbox
    taken = [t.get_window_extent(renderer) for t in (ax.title, *ax.get_legend().get_texts())]
    taken.append(ax.get_legend().get_window_extent(renderer))
    node_px = 8 * fig.dpi / 72  # half a drawn node (a 260 pt^2 marker is 16 pt across)
    nodes = {n: Bbox.from_extents(x - node_px, y - node_px, x + node_px, y + node_px)
             for n, (x, y) in ((n, ax.transData.transform(pos[n])) for n in graph.nodes)}
    left_out = 0
    for n in sorted(graph.nodes, key=lambda v: (-graph.degree(v), str(v))):  # crowded nodes choose first
        placed = None
        for radius in LABEL_RINGS:
            for dx, dy in LABEL_DIRECTIONS:
                norm = (dx * dx + dy * dy) ** 0.5
                offset = (dx / norm * radius, dy / norm * radius)
                text = ax.annotate(labels[n], xy=pos[n], xytext=offset, textcoords="offset points", fontsize=9,
                                   ha="center" if dx == 0 else ("left" if dx > 0 else "right"),
                                   va="center" if dy == 0 else ("bottom" if dy > 0 else "top"),
                                   bbox={"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "none",
                                         "alpha": 0.8},
                                   arrowprops={"arrowstyle": "-", "color": "#888888", "lw": 0.6,
                                               "shrinkA": 0, "shrinkB": 5} if radius >= LEADER_FROM else None)
                box = text.get_window_extent(renderer).expanded(1.04, 1.1)
                inside = page.x0 <= box.x0 and box.x1 <= page.x1 and page.y0 <= box.y0 and box.y1 <= page.y1
                if inside and not any(box.overlaps(other) for other in taken) and not any(
                        box.overlaps(disc) for m, disc in nodes.items() if m != n):
                    placed = box
                    break
                text.remove()
            if placed is not None:
                break
        if placed is None:
            left_out += 1
        else:
            taken.append(placed)
    return left_out


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
