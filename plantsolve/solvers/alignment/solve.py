"""Entry point: find conflicts, run the chosen method, build the result (the request was checked at submission)."""

from __future__ import annotations

import contextlib

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from plantsolve.schemas.alignment import AlignmentRequest, AlignmentResult
from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.alignment.canonical import canonical_order
from plantsolve.solvers.alignment.cuts import choose_cut, settled_locates, worst_measured
from plantsolve.solvers.alignment.direct import continue_closing, settle_conflict, solve_direct
from plantsolve.solvers.alignment.finalize import Outcome, build_result
from plantsolve.solvers.alignment.iterative import solve_dual_quaternion
from plantsolve.solvers.alignment.kkt import schur_in_use, use_schur
from plantsolve.solvers.alignment.model import Model, build_model, connection_errors, resolve_tolerances
from plantsolve.solvers.alignment.pcf import interpret_pcf, pcf_notes, pcf_tolerances
from plantsolve.solvers.alignment.plausibility import (
    FITTING_SPAN,
    MOVE_ANGLES,
    MOVE_EXTENT,
    MOVE_GAPS,
    PIPE_RADIUS_M,
    TYPICAL_SPAN,
    fitting_span_in_bores,
    moved_far,
)
from plantsolve.solvers.length_units import METRES
from plantsolve.solvers.base import (
    InputRejected,
    Progress,
    Solved,
    SolverError,
    no_progress,
)
from plantsolve.solvers.stages import Stages


def _direct_with_cuts(model: Model, request: AlignmentRequest, progress: Progress) -> Outcome:
    """Direct method; connections it cannot close are cut one at a time, highest impact first."""
    opts = request.options
    active = np.ones(model.n_conn, dtype=bool)
    reasons: dict[int, str] = {}
    errors: dict[int, tuple[float, float]] = {}
    iterations = 0
    rounds: list[dict] = []  # what each round solved on and the iterations it counted (the report's details)
    st = Stages(progress)
    st.stage(0.1, 0.7, "direct solve")
    # what each round solves on: "LDL^T" (the default's first round), "LDL^T/LU" (the round after the first cut: its
    # feasibility steps on the LU), "LU" (within use_schur(False), every round after a second cut, the LU's pass of a
    # round that only its continuation closed and every round after such a pass of the round after the first cut)
    mode = "LDL^T" if schur_in_use() else "LU"

    last: list = []  # the last round's pose, whose factorisation a continuation reuses

    def release() -> None:
        for held in last:
            held.state.kkt = {}  # peak memory: never two rounds' factorisations at once
        last.clear()

    def run(mode: str, budget: int, said: str):
        release()
        with use_schur(False) if mode == "LU" else contextlib.nullcontext():
            found = solve_direct(model, active, opts.pipe_stiffness, budget=budget, feasibility_on_lu=mode == "LDL^T/LU",
                                 step=lambda message: st.tick(f"direct solve{said}: {message}{cuts}"))
        last.append(found)
        return found

    def carried_on(pose):
        """The round's pose carried on by feasibility steps (None where that cannot close it) and its steps."""
        carried, taken = _continue_round(model, active, pose, opts, opts.max_iterations - iterations,
                                         lambda message: st.tick(f"direct solve: {message}{cuts}"))
        release()
        rounds.append({"factorisation": "LU", "iterations": taken, "counted": True, "continuation": True,
                       "closed": carried is not None})
        return carried, taken

    while True:
        cuts = f" ({len(reasons)} cut(s) so far)" if reasons else ""
        before = iterations
        pose = run(mode, opts.max_iterations - iterations, "")
        iterations += pose.iterations
        rounds.append({"factorisation": mode, "iterations": pose.iterations, "counted": True})
        if iterations >= opts.max_iterations:
            reason = f"iteration cap ({opts.max_iterations}) reached"
            break
        gap, ang = connection_errors(model, pose.P, pose.D)
        k = choose_cut(model, active, gap, ang)
        if k is not None:
            carried, taken = carried_on(pose)
            iterations += taken
            if carried is not None and mode != "LU":
                # the round can close: only its continuation did, from where the LDL^T's Gauss-Newton stalled (on
                # singular loops it can stall short of closing where the LU's closes), and where a crawl along the
                # loops' flat directions ends depends on where it starts. The LU's pass of the round replaces both, so
                # the answer is the all-LU path's
                rounds[-2]["counted"] = rounds[-1]["counted"] = False
                rounds.append({"factorisation": "LU", "iterations": 0, "counted": True})
                pose = run("LU", opts.max_iterations - before, " (reference LU)")
                rounds[-1]["iterations"] = pose.iterations
                iterations = before + pose.iterations
                mode = "LU" if mode == "LDL^T/LU" else mode
                gap, ang = connection_errors(model, pose.P, pose.D)
                k = choose_cut(model, active, gap, ang)
                carried = pose
                if k is not None and iterations < opts.max_iterations:
                    carried, taken = carried_on(pose)
                    iterations += taken
            if carried is not None:
                pose, k = carried, None
            elif iterations < opts.max_iterations:
                # a conflict: cut where the network comes to rest with its connections as springs, which it
                # determines, not where the round's Gauss-Newton stopped on its plateau (round-off's, hence the
                # names' and the factorisation's): on either factorisation, the same cut
                settled, settling = settle_conflict(model, active, opts.pipe_stiffness,
                                                    step=lambda message: st.tick(f"direct solve: {message}{cuts}"))
                iterations += settling
                rounds.append({"factorisation": "LU" if mode == "LU" else "LDL^T", "iterations": settling,
                               "counted": True, "settled": True})
                # among the connections the round left open: the springs also carry the scan gaps the round closed
                # (a share of them beside a small component's weights), which are no conflict
                open_gap, open_ang = connection_errors(model, pose.P, pose.D)
                left_open = active & ((open_gap > model.close_pos) | (open_ang > model.close_ang))
                settled_gap, settled_ang = connection_errors(model, settled.P, settled.D)
                # unless the round stalled far below what the springs carry there: then on the round's own pose
                located = settled_locates(model, left_open, open_gap, open_ang, settled_gap, settled_ang)
                gap, ang = (settled_gap, settled_ang) if located else (open_gap, open_ang)
                k = choose_cut(model, left_open, gap, ang)
        why = "conflict"
        if k is None:
            # closed, but a pipe may have been turned inside out (a loop that only closes with a negative
            # length): that is a conflict too; cut the worst-measured connection of the worst such pipe
            k = _flip_cut(model, active, pose)
            why = "pipe_flip"
        if k is None:
            reason = "all connections closed" if not reasons else f"closed after {len(reasons)} cut(s)"
            break
        if len(reasons) >= opts.max_cuts:
            reason = f"cut limit ({opts.max_cuts}) reached with connections still open"
            break
        active[k] = False
        reasons[k] = why
        errors[k] = (float(gap[k]), float(ang[k]))
        # the round after the first cut keeps the LDL^T but for its feasibility steps (it ends within 1e-6 mm of the
        # LU's where it closes); after a second cut every round is the LU's, so a network cut more than once gets the
        # all-LU answer bit for bit (each round starts from the measured pose: only the cuts carry over)
        mode = "LDL^T/LU" if mode == "LDL^T" else "LU"
    return Outcome(P=pose.P, D=pose.D, iterations=iterations, stop_reason=reason, active=active,
                   cut_reason=reasons, cut_errors=errors, extra={"rounds": rounds})


def _continue_round(model: Model, active: np.ndarray, pose, opts, budget: int, step):
    """A round that ended with a connection open is carried on (:func:`direct.continue_closing`) before any cut: a cut
    is decided only where the continuation stalls too, its largest residual falling by less than 10 % a step for three
    steps in a row however far each step is taken, with a residual more than 1,000 times the closing tolerance (see
    :func:`direct.continue_closing`); where it closes every connection, nothing is cut. Returns the pose it closed
    (None where it did not) and the steps taken (counted: they were spent)."""

    def closed(P, D) -> bool:
        gap, ang = connection_errors(model, P, D)
        return choose_cut(model, active, gap, ang) is None

    carried, taken = continue_closing(model, active, pose, opts.pipe_stiffness, closed, budget=min(budget, 60),
                                      step=step)
    return (carried if closed(carried.P, carried.D) else None), taken


def _flip_cut(model: Model, active: np.ndarray, pose) -> int | None:
    s0, s1 = model.pipe_ports()
    pipes = np.flatnonzero(model.is_pipe & ~model.fixed)
    if len(pipes) == 0:
        return None
    length = np.einsum("ij,ij->i", (pose.P[s1[pipes]] - pose.P[s0[pipes]]).astype(float), pose.D[s1[pipes]])
    short = model.min_length[pipes] * (1 - 1e-9) - length
    bad = short > max(model.pos_tol, 1e-12 * model.lref)
    if not np.any(bad):
        return None
    worst = pipes[bad][np.argmax(short[bad])]
    ports = (s0[worst], s1[worst])
    cand = np.flatnonzero(active & (np.isin(model.conn_a, ports) | np.isin(model.conn_b, ports)))
    if len(cand) == 0:
        return None
    return worst_measured(model, cand)


def _near_misses(request: AlignmentRequest) -> list[dict]:
    """Open ports that face an open port of another item within one bore radius (twice the default tolerance)."""
    used = {tuple(c.from_) for c in request.connections} | {tuple(c.to) for c in request.connections}
    open_ports = [(c.id, k, p, c.radius or 0.0) for c in request.components for k, p in enumerate(c.ports)
                  if (c.id, k) not in used]
    if len(open_ports) < 2:
        return []
    P = np.array([p.position for _, _, p, _ in open_ports])
    D = np.array([p.direction for _, _, p, _ in open_ports], dtype=float)
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    R = np.array([r for *_, r in open_ports])
    out = []
    for i, j in cKDTree(P).query_pairs(r=max(float(R.max()), 1e-9), output_type="ndarray"):
        dist = float(np.linalg.norm(P[i] - P[j]))
        if open_ports[i][0] != open_ports[j][0] and dist <= min(R[i], R[j]) and D[i] @ D[j] < -0.5:
            out.append({"from": [open_ports[i][0], open_ports[i][1]], "to": [open_ports[j][0], open_ports[j][1]],
                        "distance": dist})
    return sorted(out, key=lambda d: d["distance"])


def anchor_components(request: AlignmentRequest, nozzles: frozenset[str] = frozenset()) -> list[dict]:
    """One component to hold still in every connected network that has no fixed component: its tie_in,
    else an item at a line's end connection (``nozzles``, from a PCF's END-CONNECTION records), else an
    end flange (a flange with an open port), else its largest component (spans within twice the position tolerance
    or 1e-6 of the largest are equal: the coordinates' round-off); ties by where the component lies (its
    port positions to a micrometre, the lowest first), then by id: a file's ids may follow the order it is written
    in (a PCF without component identifiers), and the held component must not."""
    comps = request.components
    index = {c.id: i for i, c in enumerate(comps)}
    fixed = np.array([c.fixed or c.id in set(request.options.fixed_components) for c in comps])
    n = len(comps)
    if n == 0 or not request.connections:
        return []
    a = np.array([index[c.from_[0]] for c in request.connections])
    b = np.array([index[c.to[0]] for c in request.connections])
    _, label = connected_components(sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n)), directed=False)
    used = {tuple(c.from_) for c in request.connections} | {tuple(c.to) for c in request.connections}
    has_conn = np.zeros(n, dtype=bool)
    has_conn[a] = has_conn[b] = True
    # two printed coordinates each off by up to the position tolerance (a PCF: its printed precision)
    span_tie = 2 * resolve_tolerances(request)[0]
    out = []
    for net in np.unique(label[has_conn]):
        members = np.flatnonzero(label == net)
        if np.any(fixed[members]):
            continue

        def tier_span(i: int) -> tuple[int, float]:
            c = comps[i]
            P = np.array([p.position for p in c.ports], dtype=float)
            span = float(np.max(np.linalg.norm(P - P[0], axis=1))) if len(P) > 1 else 0.0
            open_port = any((c.id, k) not in used for k in range(len(c.ports)))
            tier = 0 if c.type == "tie_in" else 1 if c.id in nozzles else 2 if (c.type == "flange" and open_port) else 3
            return tier, span

        def where(i: int) -> tuple:
            P = np.array([p.position for p in comps[i].ports], dtype=float)
            return tuple(sorted(tuple(np.round(P, 3).tolist())))

        ranks = {i: tier_span(i) for i in members}
        tier = min(r[0] for r in ranks.values())
        top = max(r[1] for r in ranks.values() if r[0] == tier)
        # spans within the coordinates' round-off of the largest are equal (the shipped ladder's four 2,700 mm pipes
        # differ by 1e-11 mm as written and by 2e-4 mm printed to 3 decimals: the held pipe, hence every port of the
        # answer, followed the printing)
        equal = [i for i, (t, span) in ranks.items() if t == tier and span >= top - max(span_tie, 1e-6 * top)]
        best = min(equal, key=lambda i: (where(i), comps[i].id))
        out.append({"id": comps[best].id, "network_size": int(len(members)),
                    "why": ["tie_in", "at an end connection", "end flange (open port)", "largest component"][tier]})
    return out


def solve(request: AlignmentRequest, progress: Progress = no_progress) -> Solved:
    """Align the pipe system so that every connection closes; see the package docstring. The request
    has passed :func:`~plantsolve.solvers.alignment.validation.check_input` (the job domain runs it)."""
    return Solved(_align(request, progress))


def _align(request: AlignmentRequest, progress: Progress) -> AlignmentResult:
    progress(0.0, f"building the model of {len(request.components)} components")
    anchors = anchor_components(request, _nozzles(request)) if request.options.anchor else []
    work = request
    if anchors:
        opts = request.options.model_copy(
            update={"fixed_components": list(request.options.fixed_components) + [x["id"] for x in anchors]})
        work = request.model_copy(update={"options": opts})
    model = build_model(work)
    progress(0.05, f"model built: {model.n_conn} connections")
    if model.n_comp == 0:
        raise SolverError("model", "no components")
    gap0, ang0 = connection_errors(model, model.P0, model.D0)
    if model.n_conn == 0 or (np.all(gap0 <= model.pos_tol) and np.all(ang0 <= model.ang_tol)):
        # already water-tight (e.g. a model aligned before): nothing may move, not even along flat modes
        out = Outcome(P=model.P0.copy(), D=model.D0.copy(), iterations=0,
                      stop_reason="input already within tolerance", active=np.ones(model.n_conn, dtype=bool),
                      snap=False)
        return _finish(request, model, out, progress, anchors, gap0, ang0)
    canon, ports, conns = canonical_order(work)
    out = _solve_methods(build_model(canon), canon, progress)
    return _finish(request, model, out.reordered(ports, conns), progress, anchors, gap0, ang0)


def _solve_methods(model: Model, work: AlignmentRequest, progress: Progress) -> Outcome:
    try:
        conflict = _direct_with_cuts(model, work, progress)
    except (np.linalg.LinAlgError, RuntimeError, ValueError) as exc:  # singular factorisation and friends
        raise SolverError("direct", f"the constrained least-squares solve failed: {exc}") from exc
    progress(0.7, "direct solve done" + ("" if work.options.method == "direct" else "; dual-quaternion iteration"))
    if work.options.method == "direct":
        return conflict
    out = solve_dual_quaternion(model, work.options, conflict.active, progress, may_cut=bool(conflict.cut_reason))
    out.cut_reason = {**conflict.cut_reason, **out.cut_reason}
    out.cut_errors = {**conflict.cut_errors, **out.cut_errors}
    return out


def _finish(request: AlignmentRequest, model: Model, out: Outcome, progress: Progress, anchors: list[dict],
            gap0: np.ndarray, ang0: np.ndarray) -> AlignmentResult:
    progress(0.95, "building result")
    result = build_result(request, model, out, request.options.method)
    progress(0.97, "report")
    details = result.report.details
    details["tolerance_profile"], details["tolerance_reason"] = tolerance_source(request)
    closed0 = (gap0 <= model.pos_tol) & (ang0 <= model.ang_tol)
    details["initial_max_gap"] = float(np.max(gap0, initial=0.0))
    details["initial_max_angle_deg"] = float(np.degrees(np.max(ang0, initial=0.0)))
    details["within_rounding_at_start"] = int(np.sum(closed0))
    if anchors:
        _warn(result, "anchored",
              f"{len(anchors)} connected network(s) had no fixed component: one component of each was held still so "
              "the result is reproducible; fix your tie-ins (fixed=true or options.fixed_components) to choose.",
              {"anchors": anchors})
    opened = [k for k, c in enumerate(result.connections)
              if closed0[k] and not c.cut and (c.position_error > model.pos_tol
                                                or np.radians(c.angle_error) > model.ang_tol[k])]
    if opened:
        _warn(result, "connections_opened",
              f"{len(opened)} connection(s) within tolerance at the start are open at the end: "
              f"{details.get('stop_reason')}.",
              {"connections": [{"index": k, "from": list(request.connections[k].from_),
                                "to": list(request.connections[k].to)} for k in opened[:200]]})
    if request.source_pcf is not None:
        spacers = {c.id for c in request.components if c.id.startswith("gasket-gap-")}
        joined = {c.from_[0] for c in request.connections} | {c.to[0] for c in request.connections}
        alone = [c.id for c in request.components if c.id not in joined and c.id not in spacers]
        if alone:
            _warn(result, "pcf_unconnected_items",
                  f"{len(alone)} PCF item(s) share no end point with any other within the connection tolerance "
                  "and were not aligned; raise options.connection_tolerance if they belong to the line.",
                  {"items": alone[:200]})
        near = _near_misses(request)
        if near:
            _warn(result, "pcf_near_miss",
                  f"{len(near)} pair(s) of open PCF end points face each other a little beyond the connection "
                  "tolerance and were left unconnected; raise options.connection_tolerance to join them.",
                  {"pairs": near[:200]})
        for code, message, extra, level in pcf_notes(request):
            if level == "detail":
                details[code] = extra.get("items", extra) if code == "pcf_zero_length_items" else extra
            else:
                _warn(result, code, message, extra)
    _warn_moved_far(request, model, result, gap0, ang0)
    _warn_fitting_span(request, model, result)
    _warn_radius(request, model, result)
    _warn_tolerances(request, model, result)
    result.report.message += _cuts_said(request, result, gap0, ang0)
    progress(1.0, "done")
    return result


def _end(request: AlignmentRequest, k: int) -> str:
    """Connection ``k`` by its two ends, the smaller (id, port) first: the same words whichever end the request
    names first."""
    c = request.connections[k]
    a, b = sorted([(c.from_[0], int(c.from_[1])), (c.to[0], int(c.to[1]))])
    return f"{a[0]} port {a[1]} - {b[0]} port {b[1]}"


def _cuts_said(request: AlignmentRequest, result: AlignmentResult, gap0: np.ndarray, ang0: np.ndarray) -> str:
    """What the summary says of the cuts: each connection cut, by its components and ports, with the gap and angle
    it had in the input and why it was cut (the first five in the order of their ends, then how many more)."""
    cuts = sorted(result.cut_connections, key=lambda k: _end(request, k))
    if not cuts:
        return ""
    flips = {c["index"] for w in result.report.warnings if w.code == "connections_cut" for c in w.details["cuts"]
             if c["reason"] == "pipe_flip"}
    u = request.units
    said = [f"{_end(request, k)} (input gap {gap0[k]:.3g} {u}, {np.degrees(ang0[k]):.3g} deg; "
            f"{'closing it turned a pipe inside out' if k in flips else 'it could not close with the rest: conflict'})"
            for k in cuts[:5]]
    more = f" and {len(cuts) - 5} more" if len(cuts) > 5 else ""
    return f" Cut {len(cuts)} connection(s): {'; '.join(said)}{more}."


def _warn_fitting_span(request: AlignmentRequest, model: Model, result: AlignmentResult) -> None:
    """``implausible_fitting_span``: fittings whose ports span far more or far less than their bore (see
    :func:`fitting_span_in_bores`), said with the unit mix-up the factor points to."""
    counts = np.diff(model.port_start)
    found = fitting_span_in_bores(model.P_in, counts, model.radius, ~model.is_pipe)
    if found is None:
        return
    median, n = found
    lo, hi = FITTING_SPAN
    if lo <= median <= hi:
        return
    u = request.units
    factor = TYPICAL_SPAN / median  # what would bring the median to a typical fitting's
    likely = min(((f, name) for f, name in _UNIT_MIXUPS), key=lambda x: abs(np.log(x[0] / factor)))
    # the span is a ratio of the two: coordinates too small and bores too large look alike
    mixup = (f"the coordinates look {likely[1]} (a factor of {likely[0]:.4g}), or the bores the other way round"
             if abs(np.log(likely[0] / factor)) < np.log(3.0) else "the coordinates and the bores are not in one unit")
    source = " (a PCF: its UNITS-CO-ORDS and UNITS-BORE headers)" if request.source_pcf is not None else \
        f" (the request says units '{u}')"
    _warn(result, "implausible_fitting_span",
          f"the ports of the {n} fitting(s) with a radius span {median:.3g} bores (median; plausible "
          f"{lo:g}-{hi:g}): {mixup}{source}; the tolerances, pipe lengths and gaps read in {u} are then off too.",
          {"median_span_in_bores": median, "fittings": n, "plausible": [lo, hi], "units": u})


def _warn_radius(request: AlignmentRequest, model: Model, result: AlignmentResult) -> None:
    """``implausible_pipe_radius``: the components' median outside radius, in metres, outside what plants are built
    of (:data:`PIPE_RADIUS_M`): the whole request in another unit than it says."""
    radius = model.radius[np.isfinite(model.radius)]
    if len(radius) == 0:
        return
    u = request.units
    metres = float(np.median(radius)) * METRES[u]
    lo, hi = PIPE_RADIUS_M
    if lo <= metres <= hi:
        return
    likely = "mm read as m or inches" if metres > hi else "m read as mm (or inches or feet read as mm)"
    _warn(result, "implausible_pipe_radius",
          f"the median outside radius of the {len(radius)} component(s) with one is {np.median(radius):.4g} {u} = "
          f"{metres:.4g} m (plausible {lo * 1000:g} mm to {hi:g} m): the request's numbers look to be in another "
          f"unit than '{u}' ({likely}); every length of the result is read in {u}.",
          {"median_radius": float(np.median(radius)), "median_radius_m": metres, "plausible_m": [lo, hi], "units": u})


def _warn_tolerances(request: AlignmentRequest, model: Model, result: AlignmentResult) -> None:
    """``implausible_tolerance``: an explicit ``position_tolerance`` or ``connection_tolerance`` wider than the
    components' median outside radius. A gap that wide is accepted as closed (or joins ends that far apart): no
    scan or export tolerance is as wide as the pipe; a millimetre meant in a metre request is 1000 times it."""
    radius = model.radius[np.isfinite(model.radius)]
    if len(radius) == 0:
        return
    median, u = float(np.median(radius)), request.units
    for name in ("position_tolerance", "connection_tolerance"):
        value = getattr(request.options, name)
        if value is None or value <= median or (name == "connection_tolerance" and request.source_pcf is None):
            continue
        effect = "gaps that wide are accepted as closed" if name == "position_tolerance" else \
            "ends that far apart are connected"
        _warn(result, "implausible_tolerance",
              f"options.{name} {value:g} {u} is more than the components' median outside radius ({median:.4g} {u}): "
              f"{effect} (no scan or export tolerance is as wide as the pipe); was it meant in another unit than "
              f"the request's '{u}' (a millimetre in a metre request is 1000 times it)?",
              {"field": name, "value": value, "median_radius": median, "units": u})


# factors that turn the coordinates' apparent size into the bores' unit, with the mix-up each means
_UNIT_MIXUPS = ((1e-3, "1000 times too large: mm read as m"), (1e3, "1000 times too small: m read as mm"),
                (1 / 25.4, "25.4 times too large: mm read as inches"), (25.4, "25.4 times too small: inches read as mm"),
                (1 / 304.8, "304.8 times too large: mm read as feet"), (304.8, "304.8 times too small: feet read as mm"),
                (1e-2, "100 times too large: cm read as m"), (1e1, "10 times too small: cm read as mm"))


def _warn_moved_far(request: AlignmentRequest, model: Model, result: AlignmentResult, gap0: np.ndarray,
                    ang0: np.ndarray) -> None:
    """``implausible_displacement``: components moved beyond their network's limit (see :func:`moved_far`), named in
    the warning and the summary with the connection of the largest starting gap, the likely cause."""
    disp = np.array([c.displacement for c in result.components])
    far, limit = moved_far(disp, model.P_in, model.port_comp, model.port_comp[model.conn_a],
                           model.port_comp[model.conn_b], gap0, ang0)
    if len(far) == 0:
        return
    u = request.units
    worst = int(np.argmax(gap0))
    moved = [{"id": model.ids[c], "displacement": float(disp[c]), "limit": float(limit[c])} for c in far[:200]]
    named = ", ".join(f"{m['id']} {m['displacement']:.3g} {u}" for m in moved[:5])
    more = f" and {len(far) - 5} more" if len(far) > 5 else ""
    _warn(result, "implausible_displacement",
          f"{len(far)} component(s) moved further than closing scan gaps moves anything ({named}{more}; limit "
          f"{float(limit[far[0]]):.3g} {u}, the largest of {MOVE_GAPS:g} times the network's median starting gap, "
          f"{MOVE_ANGLES:g} times its median starting angle error times its extent and {100 * MOVE_EXTENT:g} % of "
          "its extent): something dragged them, most likely a mistyped "
          f"port (the largest starting gap is {gap0[worst]:.4g} {u} at {_end(request, worst)}), a wrong "
          "connection or a misplaced tie-in.",
          {"components": moved, "largest_starting_gap": {"index": worst, "from": list(request.connections[worst].from_),
                                                           "to": list(request.connections[worst].to),
                                                           "position_error": float(gap0[worst])}})
    result.report.message += f" {len(far)} component(s) moved beyond the plausible limit: {named}{more}."


def _nozzles(request: AlignmentRequest) -> frozenset[str]:
    if request.source_pcf is None:
        return frozenset()
    try:
        return frozenset(interpret_pcf(request.source_pcf, request.options).nozzles)
    except InputRejected:
        return frozenset()


def tolerance_source(request: AlignmentRequest) -> tuple[str, str]:
    """Which profile set the tolerances, and why."""
    opts = request.options
    explicit = opts.position_tolerance is not None or opts.angle_tolerance is not None
    note = "; explicit position_tolerance/angle_tolerance override it" if explicit else ""
    if opts.tolerance_profile != "auto":
        return opts.tolerance_profile, "chosen in the options" + note
    if request.source_pcf is not None:
        try:
            t = pcf_tolerances(request.source_pcf, request.units)
            return t["profile"], t["reason"] + note
        except InputRejected:
            pass
    return "custom", "JSON request: coordinates as exact as given (1e-10)" + note

def _warn(result: AlignmentResult, code: str, message: str, details: dict) -> None:
    result.report.warnings.append(Diagnostic(code=code, message=message, details=details))
    result.report.status = "warning"
