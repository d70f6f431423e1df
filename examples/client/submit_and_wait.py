"""Submit a job to a plantsolve service, follow its progress live, save the result and the artifacts.

    .venv/bin/python examples/client/submit_and_wait.py perfmap examples/perfmap/n3_fan_map.csv \
        --options '{"model": "auto"}' -o map.json --artifacts map_artifacts

INPUT ending in .json is sent as the JSON request; any other file is uploaded (with --options).
Exit codes: 0 succeeded, 1 the job failed or was cancelled, 2 the service refused the input, 3 the job succeeded
but its result does not pass (a failed inspection, a fit not converged: the result and artifacts are saved all the
same), as the plantsolve command line exits.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from plantsolve.client import ApiError, Client, Job

EXIT_VERDICT = 3  # the command line's code for a result that does not pass


def show_progress(job: Job) -> None:
    bar = "#" * int(job.fraction * 30)
    print(f"\r[{bar:<30}] {job.fraction:4.0%} {job.status:<9} {job.message[:60]:<60}", end="", file=sys.stderr,
          flush=True)
    if job.finished:
        print(file=sys.stderr)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("kind", help="solver kind, e.g. perfmap, tube, alignment")
    parser.add_argument("input", type=Path, help="a JSON request or a file the kind accepts")
    parser.add_argument("--url", default=os.environ.get("PLANTSOLVE_URL", "http://127.0.0.1:8000"))
    parser.add_argument("--key", default=os.environ.get("PLANTSOLVE_API_KEY"), help="API key (or PLANTSOLVE_API_KEY)")
    parser.add_argument("--options", help="JSON object of options for an uploaded file")
    parser.add_argument("-o", "--output", type=Path, help="write the result JSON here (default: stdout)")
    parser.add_argument("--artifacts", type=Path, help="download every artifact into this folder")
    parser.add_argument("--timeout", type=float, default=None, help="give up after this many seconds")
    args = parser.parse_args()

    with Client(args.url, api_key=args.key) as client:
        try:
            if args.input.suffix.lower() == ".json":
                job = client.submit(args.kind, json.loads(args.input.read_text()))
            else:
                options = json.loads(args.options) if args.options else None
                job = client.submit(args.kind, file=args.input, options=options)
        except ApiError as error:
            print(f"refused: {error}", file=sys.stderr)
            for field in error.errors:
                print(f"  {field['pointer'] or '(body)'}: {field['msg']}", file=sys.stderr)
            return 2
        print(f"job {job.id} ({job.kind}) submitted", file=sys.stderr)
        job = client.wait(job, progress=show_progress, timeout=args.timeout)
        print(f"job {job.id} {job.status}: {job.summary}", file=sys.stderr)
        for warning in job.warnings:
            print(f"  warning {warning.get('code')}: {warning.get('message')}", file=sys.stderr)
        if job.status != "succeeded":
            print(json.dumps(job.report, indent=1), file=sys.stderr)
            return 1
        result = json.dumps(client.result(job), indent=1)
        if args.output:
            args.output.write_text(result)
        else:
            print(result)
        if args.artifacts:
            for path in client.download_artifacts(job, args.artifacts):
                print(f"  saved {path}", file=sys.stderr)
    if job.verdict:  # 'succeeded' says the job ran to its end, not that its answer is a pass
        print(f"job {job.id} finished, but the verdict is against the result [{job.verdict.get('code')}]: "
              f"{job.verdict.get('message')} (exit code {EXIT_VERDICT})", file=sys.stderr)
        return EXIT_VERDICT
    return 0


if __name__ == "__main__":
    sys.exit(main())
