"""Receive plantsolve's completion webhooks and verify them (Standard Webhooks), refusing forgeries and replays.

    .venv/bin/python examples/client/webhook_receiver.py --port 9000 --api-key key-a
    # then submit with ?callback_url=http://<this host>:9000/hook (the service must be allowed to reach it)

Each POST is checked with plantsolve.client.WebhookVerifier: the ``webhook-signature`` must sign
"{webhook-id}.{webhook-timestamp}.{body}" with the secret, the timestamp must be within five minutes,
and an id taken before is not acted on again. Answers: 204 taken, 200 a repeat of a taken delivery
(nothing done; a 2xx stops the service's retries), 401 not verified (the service retries: a wrong
secret shows in the job view's ``callback.error``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from threading import Lock
from typing import Callable

from plantsolve.client import WebhookReplayed, WebhookVerificationError, WebhookVerifier, webhook_secret


def make_server(host: str, port: int, secret: str, on_job: Callable[[dict], None]) -> ThreadingHTTPServer:
    """An HTTP server that calls ``on_job(job_view)`` once per verified delivery."""
    verifier, lock = WebhookVerifier(secret), Lock()

    class Handler(BaseHTTPRequestHandler):
        def do_POST(self) -> None:
            body = self.rfile.read(int(self.headers.get("Content-Length") or 0))
            try:
                with lock:  # the verifier's memory of ids is shared by the handler threads
                    view = verifier.verify(body, dict(self.headers))
            except WebhookReplayed:
                return self._answer(200)
            except WebhookVerificationError as refused:
                print(f"refused: {refused}", file=sys.stderr)
                return self._answer(401)
            try:
                on_job(view)
            except Exception:
                with lock:
                    verifier.forget(self.headers["webhook-id"])  # let the service's retry through
                raise
            self._answer(204)

        def _answer(self, status: int) -> None:
            self.send_response(status)
            self.send_header("Content-Length", "0")
            self.end_headers()

        def log_message(self, *args) -> None:
            pass

    return ThreadingHTTPServer((host, port), Handler)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on (default: %(default)s)")
    parser.add_argument("--port", type=int, default=9000, help="port to listen on (default: %(default)s)")
    given = parser.add_mutually_exclusive_group()
    given.add_argument("--secret", default=os.environ.get("PLANTSOLVE_WEBHOOK_SECRET"),
                       help="the tenant's WEBHOOK_SECRETS value, whsec_<base64> (or PLANTSOLVE_WEBHOOK_SECRET)")
    given.add_argument("--api-key", default=os.environ.get("PLANTSOLVE_API_KEY"),
                       help="the API key the jobs are submitted with, when the service derives the secret from it")
    args = parser.parse_args()
    secret = args.secret or (webhook_secret(args.api_key) if args.api_key else None)
    if not secret:
        parser.error("give --secret or --api-key")

    def show(view: dict) -> None:
        print(json.dumps({k: view.get(k) for k in ("id", "kind", "status", "message")}), flush=True)

    server = make_server(args.host, args.port, secret, show)
    print(f"listening on http://{args.host}:{server.server_address[1]}/", file=sys.stderr)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
