"""The suite's plot checker (``tests/support/plots.py``'s ``figure_problems``) on every kind's example figures, this
tree's beside another checkout's (``--before DIR``, e.g. a worktree of ``main``) in one process, in turn, ``--repeat``
times: the CPU seconds of each (the least over the repeats) and whether both found the same problems, on the kinds'
figures at their own and at the saved resolution and on a figure that breaks the checker's rules.

    python bench/plot_checker.py --before /tmp/main [--repeat 3]
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def checker(root: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, root / "tests" / "support" / "plots.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.figure_problems


def broken_figure():
    """A figure against every rule: a legend over the data, tiny text, text over text, dark text on a dark image, a
    title off the page, no units."""
    import numpy as np
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4, 3))
    ax = fig.add_subplot()
    ax.plot(np.linspace(0, 1, 50), np.linspace(0, 1, 50), label="data line")
    ax.legend(loc="center")
    ax.text(0.5, 0.5, "overlap one", fontsize=4)
    ax.text(0.5, 0.5, "overlap two", color="#fefefe")
    ax.imshow(np.ones((5, 5)), extent=(0.2, 0.6, 0.2, 0.6))
    ax.set_title("a title long enough to run off the edge of the figure whatever the font, surely")
    return fig


def cases():
    """(name, make a fresh figure, dpi, tolerances) for every kind's example figure at two resolutions, and the
    broken figure."""
    from plantsolve.solvers.kinds import KINDS

    out = []
    for kind in sorted(KINDS):
        spec = KINDS[kind]
        job_input = spec.input_of(spec.request_model.model_validate(spec.example()))
        result = spec.solve(job_input, lambda *_: None).result
        artifacts = importlib.import_module(f"plantsolve.solvers.{kind}.artifacts")
        declared = artifacts.tolerances(job_input, result) if hasattr(artifacts, "tolerances") else {}
        for stem in artifacts.figures(job_input, result):
            make = (lambda a=artifacts, i=job_input, r=result, s=stem: a.figures(i, r)[s])
            out += [(f"{kind}/{stem}", make, dpi, declared.get(stem, [])) for dpi in (None, 110)]
    return out + [("broken figure", broken_figure, dpi, []) for dpi in (None, 110)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--before", type=Path, required=True, help="another checkout (a worktree of main)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    trees = {"before": checker(args.before.resolve(), "before_plots"), "this": checker(REPO, "this_plots")}
    figures = cases()
    best = {name: float("inf") for name in trees}
    found = {}
    for _ in range(args.repeat):
        for name, figure_problems in trees.items():
            made = [(label, make(), dpi, tolerances) for label, make, dpi, tolerances in figures]
            start = time.process_time()
            found[name] = [(label, dpi, figure_problems(fig, dpi, tolerances)) for label, fig, dpi, tolerances in made]
            best[name] = min(best[name], time.process_time() - start)
    print(f"{len(figures)} figure checks, least of {args.repeat} runs each")
    print(f"{'checker':<8} {'CPU s':>7} {'x before':>9}  problems found")
    for name in trees:
        count = sum(len(problems) for _, _, problems in found[name])
        print(f"{name:<8} {best[name]:7.2f} {best[name] / best['before']:8.2f}x  {count}")
    print("same findings on every figure:", found["this"] == found["before"])


if __name__ == "__main__":
    main()
