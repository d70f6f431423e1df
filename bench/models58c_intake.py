"""CPU seconds and peak RSS of the intake paths models58c fixed, this checkout against another (``--before DIR``: a
checkout of another revision, only read, e.g. ``git archive integ | tar -x -C DIR``):

- dedup intake's world check over 4,000 representation contexts in one chunk (290 kB: a JSON request's size, judged
  in the web process);
- dedup intake of the zoo model with its DATA section on one line, and of the tunnel two instances a line;
- the rigidity LDraw reader on 40,000 lines placing one sub-model the file does not hold.

Each case runs in a fresh process, the codes interleaved (this, before, this, ...), ``--repeat N`` times; the least
CPU time of each is printed. A refused file's answer is printed beside it (``422``), an accepted one as ``ok``.

    python bench/models58c_intake.py --before /tmp/integ --repeat 3
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent

CASE = r'''
import json, resource, sys, time
case = sys.argv[1]
from tests.conftest import REPO
from plantsolve.solvers.base import InputRejected, StoredInput

def intake(text):
    from plantsolve.solvers.dedup import SPEC
    from plantsolve.solvers.dedup.upload import parse_upload
    source = StoredInput.from_bytes("model.ifc", text.encode())
    try:
        SPEC.check_input(SPEC.input_of(parse_upload(source, {}), source))
        return "ok"
    except InputRejected as e:
        return "422 " + e.errors[0].msg[:50]

def two_per_line(text):
    head, data = text.split("DATA;\n", 1)
    body, tail = data.split("ENDSEC;", 1)
    lines = body.splitlines()
    return head + "DATA;\n" + "\n".join("".join(lines[i:i + 2]) for i in range(0, len(lines), 2)) + "\nENDSEC;" + tail

if case == "contexts":
    from plantsolve.solvers.dedup.validation import refuse_unplaceable_world
    text = "".join(f"#{k}=IFCCARTESIANPOINT((0.,0.,0.));\n#{k + 1}=IFCAXIS2PLACEMENT3D(#{k},$,$);\n"
                   f"#{k + 2}=IFCGEOMETRICREPRESENTATIONCONTEXT($,'Model',3,1.E-05,#{k + 1},$);\n"
                   for k in range(1000, 13000, 3)).encode()
    run = lambda: refuse_unplaceable_world(text, "IFC4") or "ok"
elif case == "zoo one line":
    text = (REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc").read_text().replace("\n", "")
    run = lambda: intake(text)
elif case == "tunnel two a line":
    text = two_per_line((REPO / "examples" / "dedup" / "tunnel_3rings.ifc").read_text())
    run = lambda: intake(text)
elif case == "ldraw 40,000 missing":
    from plantsolve.solvers.rigidity.upload import parse_ldraw
    text = "0 FILE main.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n" + "".join(
        f"1 16 {k} 0 0 1 0 0 0 1 0 0 0 1 gone.ldr\n" for k in range(40_000))
    run = lambda: parse_ldraw(text) and "ok"
start = time.process_time()
answer = run()
print(json.dumps({"cpu": time.process_time() - start, "answer": answer,
                  "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
'''
CASES = ("contexts", "zoo one line", "tunnel two a line", "ldraw 40,000 missing")


def measure(root: Path, case: str) -> dict:
    done = subprocess.run([sys.executable, "-c", CASE, case], cwd=root, capture_output=True, text=True, check=True,
                          env={"PYTHONPATH": str(root), "PYTHONDONTWRITEBYTECODE": "1", "PATH": "/usr/bin:/bin"})
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path, help="a checkout of the revision to compare with")
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    codes = {"this": HERE, **({"before": args.before} if args.before else {})}
    best: dict[tuple[str, str], dict] = {}
    for _ in range(args.repeat):
        for case in CASES:
            for code, root in codes.items():
                got = measure(root, case)
                if (case, code) not in best or got["cpu"] < best[case, code]["cpu"]:
                    best[case, code] = got
    print(f"{'case':24} {'code':7} {'CPU s':>8} {'peak RSS MB':>12}  answer")
    for case in CASES:
        for code in codes:
            got = best[case, code]
            print(f"{case:24} {code:7} {got['cpu']:8.3f} {got['rss_mb']:12.0f}  {got['answer']}")


if __name__ == "__main__":
    main()
