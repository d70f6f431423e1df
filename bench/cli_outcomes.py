"""What ``plantsolve solve`` tells its user, this checkout beside another (``--before``, default: the ``main``
branch) in the same run: for each shipped example, each result with a verdict against it (a failed inspection, a
fit stopped before it converged) and each usual mistake (a misspelt option or field, a file of another kind, an
output that cannot be written, a store that cannot be opened), the exit code, the last line on standard error
(cut to ``--width``), whether a traceback was printed, the CPU seconds (user + system, the command and the
processes it waited for) and the peak resident memory. Numbers are best of ``--repeat``, the two checkouts
interleaved.

    python bench/cli_outcomes.py [--repeat N] [--before main|DIR] [--width 100] [--only tube,mistake]
"""

from __future__ import annotations

import argparse
import io
import json
import os
import re
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"


def cases(scratch: Path) -> list[tuple[str, str, list[str]]]:
    """(group, name, arguments after ``solve``); files the cases need are written into ``scratch``."""
    ladder = json.loads((EXAMPLES / "alignment" / "ladder.json").read_text())
    capped = {**ladder, "options": {**ladder.get("options", {}), "max_iterations": 1}}
    (scratch / "ladder_capped.json").write_text(json.dumps(capped))
    typo = json.loads((EXAMPLES / "tube" / "scan_request.json").read_text())
    typo["pionts"] = typo.pop("points")
    (scratch / "tube_typo.json").write_text(json.dumps(typo))
    (scratch / "a_folder").mkdir(exist_ok=True)
    (scratch / "a_file").write_text("")
    example = [("alignment", "alignment/ladder.json", []), ("alignment", "alignment/ladder.pcf", []),
               ("tube", "tube/scan.xyz", []), ("tube", "tube/scan.ply", []),
               ("perfmap", "perfmap/n3_fan_map.csv", []), ("dedup", "dedup/tunnel_3rings.ifc", []),
               ("rigidity", "rigidity/hinged_wall.ldr", []), ("flowmeter", "flowmeter/meter.json", []),
               ("polyhedra", "polyhedra/two_offices.idf", []), ("polyhedra", "polyhedra/gable_house.json", [])]
    out = [("example", f"{kind} {file}", [kind, str(EXAMPLES / file), *extra]) for kind, file, extra in example]
    out += [
        ("verdict", "tube inspection FAIL (scan_request.json)", ["tube", str(EXAMPLES / "tube/scan_request.json")]),
        ("verdict", "alignment not converged (max_iterations 1)", ["alignment", str(scratch / "ladder_capped.json")]),
        ("mistake", "--optoins (typo)", ["tube", str(EXAMPLES / "tube/scan.ply"), "--optoins", "{}"]),
        ("mistake", "--options unit (typo)", ["tube", str(EXAMPLES / "tube/scan.ply"), "--options", '{"unit": "mm"}']),
        ("mistake", "request key pionts (typo)", ["tube", str(scratch / "tube_typo.json")]),
        ("mistake", ".pcf given to tube", ["tube", str(EXAMPLES / "alignment/ladder.pcf")]),
        ("mistake", "-o names a folder", ["polyhedra", str(EXAMPLES / "polyhedra/gable_house.json"), "-o",
                                          str(scratch / "a_folder")]),
        ("mistake", "--data-dir is a file", ["polyhedra", str(EXAMPLES / "polyhedra/gable_house.json"), "--data-dir",
                                             str(scratch / "a_file")]),
        ("mistake", "--store postgres:// (no dialect)", ["polyhedra", str(EXAMPLES / "polyhedra/gable_house.json"),
                                                         "--store", "postgres://u@127.0.0.1:1/db"]),
        ("mistake", "INPUT is a folder", ["tube", str(EXAMPLES / "tube")]),
    ]
    return [(group, name, ["solve", *args]) for group, name, args in out]


def run(root: Path, argv: list[str], cwd: Path) -> dict:
    """One ``python -m plantsolve.cli`` with ``root`` first on the path: exit code, stderr, CPU s, peak RSS MB."""
    env = {**os.environ, "PYTHONPATH": str(root), "DATA_DIR": str(cwd / "var")}
    argv = [*argv] if "-o" in argv else [*argv, "-o", str(cwd / "out.json")]
    with tempfile.TemporaryFile() as err:
        started = time.perf_counter()
        process = subprocess.Popen([sys.executable, "-m", "plantsolve.cli", *argv, "--no-progress"], cwd=cwd, env=env,
                                   stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(process.pid, 0)
        process.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - started
        err.seek(0)
        text = err.read().decode(errors="replace")
    # the pointer to --json says nothing of the case: the field's line above it does
    lines = [ln for ln in text.splitlines() if ln.strip() and ln.strip() != "(--json prints the whole problem document)"]
    return {"code": process.returncode, "last": lines[-1].strip() if lines else "", "traceback": "Traceback" in text,
            "cpu": usage.ru_utime + usage.ru_stime, "rss": usage.ru_maxrss / 1024, "wall": wall}


def checkout_of(spec: str, scratch: Path) -> Path:
    """``--before``: a folder as it is, or a git revision's ``plantsolve`` package unpacked into ``scratch``."""
    if Path(spec).is_dir():
        return Path(spec)
    folder = scratch / "before"
    folder.mkdir()
    archive = subprocess.run(["git", "-C", str(REPO), "archive", "--format=tar", spec, "plantsolve"], check=True,
                             capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(folder, filter="data")
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(folder / "plantsolve")], check=True)
    return folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--before", default="main", help="a git revision or a source folder (default: main)")
    parser.add_argument("--width", type=int, default=100, help="characters of the last line shown")
    parser.add_argument("--only", default="", help="comma-separated groups (example, verdict, mistake)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-cli-outcomes-") as folder:
        scratch = Path(folder)
        sides = {"before": checkout_of(args.before, scratch), "after": REPO}
        wanted = set(filter(None, args.only.split(",")))
        print("| group | case | exit before → after | traceback | CPU s before / after | peak RSS MB before / after "
              "| last line before | last line after |")
        print("|---|---|---|---|---|---|---|---|")
        for group, name, argv in cases(scratch):
            if wanted and group not in wanted:
                continue
            runs: dict[str, list[dict]] = {side: [] for side in sides}
            for _ in range(args.repeat):
                for side, root in sides.items():  # a folder of its own: no run finds another's artifacts
                    runs[side].append(run(root, argv, Path(tempfile.mkdtemp(prefix=f"{side}-", dir=scratch))))
            b, a = (min(runs[s], key=lambda r: r["cpu"]) for s in ("before", "after"))
            print(f"| {group} | {name} | {b['code']} → {a['code']} | {'yes' if b['traceback'] else 'no'} → "
                  f"{'yes' if a['traceback'] else 'no'} | {b['cpu']:.2f} / {a['cpu']:.2f} | {b['rss']:.0f} / "
                  f"{a['rss']:.0f} | {shown(b, folder, args.width)} | {shown(a, folder, args.width)} |", flush=True)


def shown(run: dict, scratch: str, width: int) -> str:
    """A run's last line for the table: a job's id and the scratch folder are noise beside what it says."""
    line = re.sub(r"[0-9a-f]{8}(-[0-9a-f]{4}){3}-[0-9a-f]{12}", "<id>", run["last"]).replace(scratch, "…")
    return line[:width].replace("|", "\\|")


if __name__ == "__main__":
    main()
