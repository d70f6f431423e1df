"""CPU seconds of dedup's intake scan on IFC text with a quote that never closes (a hostile or broken file), and on
the zoo model for scale: the instance texts were cut by walking every ';' to the end of the text once per entity.

    python bench/step_open_quote.py                     # this checkout
    python bench/step_open_quote.py --before DIR        # and the code in DIR (e.g. a checkout of integ), interleaved

Each case runs in a fresh process (least of --repeat); prints a table of CPU seconds and peak RSS."""

from __future__ import annotations

import argparse
import json
import pathlib
import subprocess
import sys

HERE = pathlib.Path(__file__).resolve().parent.parent

CASE = r'''
import json, resource, sys, time
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC, validation
from plantsolve.solvers.dedup.upload import parse_upload
zoo = open(sys.argv[2]).read()
if sys.argv[1] == "open quote":
    names = sorted(validation._entities("IFC2X3"))
    body = "#999000=IFCBUILDINGELEMENTPROXY('never closed,$,$,$,$,$,$,$,$);\n" + "".join(
        f"#{999001 + k}=IFCBUILDINGELEMENTPROXY('b{k}',$,$,$,$,$,$,$,$);\n" for k in range(15_000))
    body += "".join(f"#{990000 + k}={name.decode()}($);\n" for k, name in enumerate(names))
    zoo = zoo.replace("DATA;\n", "DATA;\n" + body, 1)
data = zoo.encode()
source = StoredInput.from_bytes("model.ifc", data)
start = time.process_time()
try:
    SPEC.check_input(SPEC.input_of(parse_upload(source, {}), source))
    outcome = "accepted"
except InputRejected as e:
    outcome = "422: " + e.errors[0].msg[:50]
cpu = time.process_time() - start
print(json.dumps({"cpu": cpu, "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "mb": len(data) / 1e6, "outcome": outcome}))
'''


def _run(code: pathlib.Path, case: str) -> dict:
    out = subprocess.run([sys.executable, "-c", CASE, case, str(HERE / "examples/dedup/zoo_ifc2x3.ifc")],
                         cwd=code, env={"PYTHONPATH": str(code)}, capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--before", type=pathlib.Path)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    codes = {"this": HERE} | ({"before": args.before} if args.before else {})
    print(f"{'case':<11} {'code':<7} {'MB':>5} {'CPU s':>7} {'peak RSS MB':>12}  outcome")
    for case in ("zoo", "open quote"):
        best: dict[str, dict] = {}
        for _ in range(args.repeat):
            for name, code in codes.items():  # interleaved
                found = _run(code, case)
                if name not in best or found["cpu"] < best[name]["cpu"]:
                    best[name] = found
        for name, found in best.items():
            print(f"{case:<11} {name:<7} {found['mb']:>5.2f} {found['cpu']:>7.3f} {found['rss_mb']:>12.0f}  "
                  f"{found['outcome']}")


if __name__ == "__main__":
    main()
