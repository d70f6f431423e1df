"""Hostile submissions against the real server: status, seconds and server RSS growth per case.

Starts ``plantsolve serve`` (embedded default, SQLite, a private data dir) on a loopback port with its output
in a file, sends each case at full size, and prints a table: case, status, seconds to answer, growth of the
API process's RSS over its idle baseline (peak sampled every 50 ms while the case runs) and of the whole
process tree (the forkserver and the bounded reading processes included). Last, SIGTERM during a hostile
parse: how long the server takes to exit.

The damaged-file cases are the repository's own example and public files with one flaw each (a coordinate of
1e308, a UTF-16 save, a stray quote, a corrupt deflate stream, a cut IFC): their status says whether the file
is read (202) or refused (422), and the server log whether a reader failed ('failed in the reader').
``--before DIR`` runs every case on the checkout in DIR too (its own ``.venv``), after this one, in the same run.

``--http`` runs the HTTP-level cases instead (:func:`http_cases`, raw sockets): bodies far above or below what they
declare, one that stalls, 10k multipart parts, deep nesting, invalid UTF-8, a compressed body, query parameters out
of range or unknown, path traversal in artifact names, a client that leaves mid-body. Each row: the status line, whether
the answer is a problem document, seconds, the API process's RSS growth; last, the server log's tracebacks.

    python bench/hostile.py [--port 8765] [--before /tmp/base] [--http]
"""

from __future__ import annotations

import argparse
import gzip
import io
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import zipfile
from pathlib import Path

import httpx

BIN = Path(sys.executable).parent


def alignment_connections(n: int) -> tuple[str, bytes, dict]:
    conns = ",".join('{"from":["C%d",0],"to":["C%d",1]}' % (i, i + 1) for i in range(n))
    body = ('{"components":[{"id":"C0","kind":"fitting","ports":[{"position":[0,0,0],"direction":[1,0,0]}]}],'
            '"connections":[' + conns + "]}").encode()
    return "alignment", body, {"Content-Type": "application/json"}


def rigidity_joints(n: int):
    joint = '{"type":"revolute","bodies":["a","b"],"point":[0,0,0],"axis":[0,0,1]}'
    return "rigidity", ('{"joints":[' + ",".join([joint] * n) + "]}").encode(), {"Content-Type": "application/json"}


def polyhedra_faces(n: int):
    faces = ",".join('{"id":"f%d","loops":[[0,1,2]]}' % i for i in range(n))
    return "polyhedra", ('{"vertices":[[0,0,0],[1,0,0],[0,1,0]],"faces":[' + faces + "]}").encode(), \
        {"Content-Type": "application/json"}


def xlsx(member: str, data: bytes) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("[Content_Types].xml", '<?xml version="1.0"?><Types/>')
        archive.writestr(member, data)
    return buffer.getvalue()


def xlsx_bomb(inflated: int) -> bytes:
    """A workbook whose sheet inflates to ``inflated`` bytes, written in chunks (the bench never holds them)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("[Content_Types].xml", '<?xml version="1.0"?><Types/>')
        with archive.open("xl/worksheets/sheet1.xml", "w", force_zip64=True) as member:
            chunk = b"a" * (1 << 24)
            for _ in range(inflated // len(chunk)):
                member.write(chunk)
    return buffer.getvalue()


def ldraw_fan_out() -> bytes:
    lines = []
    for level in range(8):
        lines.append(f"0 FILE m{level}.ldr")
        child = f"m{level + 1}.ldr" if level < 7 else "3001.dat"
        lines += [f"1 16 {i} 0 0 1 0 0 0 1 0 0 0 1 {child}" for i in range(10)]
    return ("\n".join(lines) + "\n").encode()


ROOT = Path(__file__).resolve().parents[1]


def damaged_files():
    """(case, kind, file name, bytes): example and public files of the repository, each with one flaw."""
    pcf = (ROOT / "examples/alignment/ladder.pcf").read_text()
    yield "PCF, one coordinate 1e308", "alignment", "ladder.pcf", pcf.replace("200000.0000", "1e308", 1).encode()
    yield "PCF saved as UTF-16", "alignment", "ladder.pcf", pcf.encode("utf-16")
    yield "OMR 889 .mpd (rotations to 3 digits)", "rigidity", "889.mpd", \
        (ROOT / "tests/solvers/rigidity/omr/889-1-RadarTruck.mpd").read_bytes()
    ldr = (ROOT / "examples/rigidity/hinged_wall.ldr").read_text().splitlines(keepends=True)
    part = next(i for i, line in enumerate(ldr) if line.startswith("1 "))
    ldr[part] = "1 4 1e308 " + ldr[part].split(None, 3)[3]  # its x
    yield "LDraw, one position 1e308", "rigidity", "wall.ldr", "".join(ldr).encode()
    meter = (ROOT / "examples/flowmeter/meter.json").read_text()
    yield "flowmeter JSON saved as UTF-16", "flowmeter", "meter.json", meter.encode("utf-16")
    lines = (ROOT / "examples/perfmap/n3_fan_map.csv").read_text().splitlines()
    lines[5] = '"' + lines[5]
    yield "perfmap CSV, one stray quote", "perfmap", "map.csv", ("\n".join(lines) + "\n").encode()
    lines[5] = "1 " * 100_000
    yield "perfmap CSV, one 200 KB field", "perfmap", "map.csv", ("\n".join(lines) + "\n").encode()
    xyz = (ROOT / "examples/tube/scan.xyz").read_text().splitlines()
    xyz[10] = "1e308 0 0"
    yield "XYZ, one line 1e308", "tube", "scan.xyz", ("\n".join(xyz) + "\n").encode()
    yield "XYZ saved as UTF-16", "tube", "scan.xyz", (ROOT / "examples/tube/scan.xyz").read_text().encode("utf-16")
    ifc = (ROOT / "examples/dedup/tunnel_3rings.ifc").read_bytes()
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("model.ifc", ifc)
    damaged = bytearray(buffer.getvalue())
    damaged[30 + len("model.ifc") + 40:30 + len("model.ifc") + 48] = b"\xff" * 8
    yield ".ifczip, corrupt deflate stream", "dedup", "model.ifczip", bytes(damaged)
    yield "IFC behind a UTF-8 mark", "polyhedra", "spaces.ifc", \
        b"\xef\xbb\xbf" + (ROOT / "tests/solvers/polyhedra/data/ifcopenshell_spaces.ifc").read_bytes()


def cases():
    yield "alignment 10^6 connections (JSON)", *alignment_connections(1_000_000), None
    yield "rigidity 10^6 joints (JSON)", *rigidity_joints(1_000_000), None
    yield "polyhedra 10^6 faces (JSON)", *polyhedra_faces(1_000_000), None
    yield "xlsx zip bomb (2 GiB inflated)", "perfmap", None, None, ("rig.xlsx", xlsx_bomb(2 * 1024**3))
    dtd = (b'<?xml version="1.0"?><!DOCTYPE l [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">'
           b']><workbook>&b;</workbook>')
    yield "xlsx DTD entity expansion", "perfmap", None, None, ("rig.xlsx", xlsx("xl/workbook.xml", dtd))
    yield "LDraw .mpd fan-out 8 x 10", "rigidity", None, None, ("fan.mpd", ldraw_fan_out())
    line = b"1234.5678 2345.6789 3456.7891\n"
    yield "64 MB .xyz", "tube", None, None, ("scan.xyz", line * (64 * 1024 * 1024 // len(line)))
    for name, kind, file_name, content in damaged_files():  # last: the jobs they start run after the cases above
        yield name, kind, None, None, (file_name, content)


def rss(pid: int) -> int:
    """Resident set size of a process in bytes (from /proc; 0 once it is gone)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def descendants(pid: int) -> list[int]:
    found, todo = [], [pid]
    while todo:
        parent = todo.pop()
        for task in Path(f"/proc/{parent}/task").glob("*"):
            try:
                children = [int(c) for c in (task / "children").read_text().split()]
            except OSError:
                continue
            found += children
            todo += children
    return found


def tree_rss(pid: int) -> int:
    return rss(pid) + sum(rss(child) for child in descendants(pid))


class Peak:
    """Peak RSS of the server and of its process tree while a case runs."""

    def __init__(self, pid: int):
        self.pid = pid
        self.server = self.tree = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _sample(self) -> None:
        self.server, self.tree = max(self.server, rss(self.pid)), max(self.tree, tree_rss(self.pid))

    def _run(self) -> None:
        while not self._stop.is_set():
            self._sample()
            time.sleep(0.05)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()


def start(port: int, data_dir: str, log_path: Path, bin_dir: Path = BIN, **settings: str) -> subprocess.Popen:
    env = {**os.environ, "DATA_DIR": data_dir, "API_KEYS": "", "EMBEDDED_WORKERS": "1", **settings}
    log = open(log_path, "wb")
    server = subprocess.Popen([str(bin_dir / "plantsolve"), "serve", "--host", "127.0.0.1", "--port", str(port)],
                              stdout=log, stderr=subprocess.STDOUT, env=env, cwd=bin_dir.parents[1])
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1).status_code < 500:
                return server
        except httpx.HTTPError:
            time.sleep(0.3)
    raise SystemExit(f"the server did not start; see {log_path}")


def send(base: str, kind: str, body, headers, upload) -> tuple[int, float, str | None]:
    """Status and seconds of the answer, and the job's id when one was accepted."""
    begin = time.monotonic()
    with httpx.Client(timeout=120) as client:
        if upload is not None:
            response = client.post(f"{base}/v1/{kind}/jobs", files={"file": upload})
        else:
            response = client.post(f"{base}/v1/{kind}/jobs", content=body, headers=headers)
    job = response.json().get("id") if response.status_code == 202 else None
    return response.status_code, time.monotonic() - begin, job


def outcome(base: str, job: str | None, timeout: float = 300) -> str:
    """How an accepted job ended: its status, with the warnings it carries ('-' when none was accepted)."""
    if job is None:
        return "-"
    deadline = time.monotonic() + timeout
    with httpx.Client(timeout=30) as client:
        while time.monotonic() < deadline:
            view = client.get(f"{base}/v1/jobs/{job}").json()
            if view["status"] in ("succeeded", "failed", "cancelled"):
                warnings = len((view.get("report") or {}).get("warnings") or [])
                return f"{view['status']}" + (f" ({warnings} w)" if warnings else "")
            time.sleep(0.5)
    return "running"


def run(label: str, port: int, bin_dir: Path) -> dict[str, tuple[int, float, int, int, bool]]:
    """Every case against a server started from ``bin_dir``: status, seconds, server and tree RSS growth, and
    whether the server log says a reader failed on it."""
    base = f"http://127.0.0.1:{port}"
    rows = {}
    with tempfile.TemporaryDirectory(prefix="plantsolve-hostile-") as data_dir:
        log_path = Path(data_dir) / "server.log"
        server = start(port, data_dir, log_path, bin_dir)
        time.sleep(5)  # the forkserver of the upload readers starts in the background
        baseline, tree_base = rss(server.pid), tree_rss(server.pid)
        print(f"[{label}] server idle RSS {baseline / 2**20:.0f} MiB (tree {tree_base / 2**20:.0f} MiB)", flush=True)
        for name, kind, body, headers, upload in cases():
            logged = log_path.stat().st_size
            with Peak(server.pid) as peak:
                status, seconds, job = send(base, kind, body, headers, upload)
            ended = outcome(base, job)  # waited for, so that no job runs under the next case
            with open(log_path, "rb") as log:
                log.seek(logged)
                crashed = b"failed in the reader" in log.read()
            rows[name] = (status, seconds, peak.server - baseline, peak.tree - tree_base, crashed, ended)
        # SIGTERM while a hostile upload is being read
        _, kind, body, headers, upload = next(c for c in cases() if c[0].startswith("64 MB"))
        sender = threading.Thread(target=lambda: send(base, kind, body, headers, upload), daemon=True)
        sender.start()
        time.sleep(0.5)
        begin = time.monotonic()
        server.send_signal(signal.SIGTERM)
        try:
            server.wait(timeout=30)
            print(f"[{label}] SIGTERM during a hostile upload: the server exited after {time.monotonic() - begin:.2f} s")
        except subprocess.TimeoutExpired:
            print(f"[{label}] SIGTERM during a hostile upload: the server did not exit within 30 s; killing it")
            server.kill()
            server.wait()
    return rows


# the server's wait for a stalled body in --http (BODY_IDLE_SECONDS; a checkout without the setting ignores it)
HTTP_IDLE_SECONDS = 5


def raw(port: int, head: bytes, body=(), *, pause: float = 0.0, half_close: bool = False,
        timeout: float = 60) -> bytes:
    """Send ``head`` and the parts of ``body`` (``pause`` seconds after the first part) on a new connection; the
    answer as far as it came (``<no answer>`` when the server closed without one, ``<open>`` when it said nothing
    within ``timeout``)."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
    data = b""
    try:
        try:
            for index, part in enumerate([head, *body]):
                sock.sendall(part)
                if index == 1 and pause:
                    time.sleep(pause)
            if half_close:
                sock.shutdown(socket.SHUT_WR)
        except OSError:  # the server answered before the whole request was sent, and closed
            pass
        while b"\r\n\r\n" not in data or len(data.partition(b"\r\n\r\n")[2]) < _length(data):
            chunk = sock.recv(65536)
            if not chunk:
                break
            data += chunk
        return data or b"<no answer>"
    except socket.timeout:
        return data or b"<open>"
    except OSError:
        return data or b"<reset>"
    finally:
        sock.close()


def _length(data: bytes) -> int:
    for line in data.partition(b"\r\n\r\n")[0].split(b"\r\n"):
        if line.lower().startswith(b"content-length:"):
            return int(line.split(b":")[1])
    return 1 << 62


def request(method: str, path: str, body: bytes = b"", content_type: str = "application/json", extra: str = "",
            length: int | None = None) -> bytes:
    return (f"{method} {path} HTTP/1.1\r\nHost: x\r\nContent-Type: {content_type}\r\n"
            f"Content-Length: {len(body) if length is None else length}\r\n{extra}Connection: close\r\n\r\n"
            ).encode("latin-1") + body


def multipart(parts: list[tuple[str, str | None, bytes]]) -> tuple[bytes, str]:
    boundary = "plantsolvebench"
    body = b"".join(f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"'.encode()
                    + (f'; filename="{filename}"'.encode() if filename else b"") + b"\r\n\r\n" + data + b"\r\n"
                    for name, filename, data in parts) + f"--{boundary}--\r\n".encode()
    return body, f"multipart/form-data; boundary={boundary}"


def http_cases(base: str, port: int):
    """(case, thunk returning the raw answer): the HTTP-level cases of ``--http``."""
    meter = (ROOT / "examples/flowmeter/meter.json").read_bytes()
    submit = "/v1/flowmeter/jobs"
    yield "300 MB declared (above MAX_BODY_BYTES)", lambda: raw(port, request("POST", submit, length=300 << 20))
    yield "2 GB declared, 15 bytes sent", lambda: raw(port, request("POST", submit, b'{"sections": [1', length=2 << 30))
    yield "150 MB declared, 15 sent, then EOF", lambda: raw(
        port, request("POST", submit, b'{"sections": [1', length=150 << 20), half_close=True, timeout=30)
    yield f"body stalls {HTTP_IDLE_SECONDS + 3} s half way", lambda: raw(
        port, request("POST", submit, length=len(meter)), [meter[:20], meter[20:]], pause=HTTP_IDLE_SECONDS + 3)

    def chunked() -> bytes:
        head = (f"POST {submit} HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                "Transfer-Encoding: chunked\r\nConnection: close\r\n\r\n").encode()
        frame = b"100000\r\n" + b" " * 0x100000 + b"\r\n"
        return raw(port, head, [frame] * 300 + [b"0\r\n\r\n"])
    yield "300 MB chunked (no length)", chunked
    yield "JSON nested 100k deep", lambda: raw(port, request("POST", submit, b"[" * 100_000 + b"]" * 100_000))
    yield "multipart, 10k fields", lambda: raw(port, request(
        "POST", submit, *multipart([(f"f{i}", None, b"v") for i in range(10_000)])))
    yield "multipart, 10k files", lambda: raw(port, request(
        "POST", submit, *multipart([("file", f"m{i}.json", meter) for i in range(10_000)])))
    yield "invalid UTF-8 in a JSON string", lambda: raw(port, request(
        "POST", submit, meter.replace(b'"', b'"\xff', 1)))
    yield "gzip body, Content-Encoding: gzip", lambda: raw(port, request(
        "POST", submit, gzip.compress(meter), extra="Content-Encoding: gzip\r\n"))
    yield "plain body labelled gzip", lambda: raw(port, request("POST", submit, meter,
                                                                extra="Content-Encoding: gzip\r\n"))
    yield "callback URL misspelt (?callbackurl=)", lambda: raw(port, request(
        "POST", f"{submit}?callbackurl=https://example.com/hook", meter))
    for query in ("limit=-1", "limit=" + "9" * 30, "cursor=%25%25garbage", "cursor=eyJhIjogMX0", "stauts=failed"):
        yield f"GET /v1/jobs?{query}", lambda query=query: raw(port, request("GET", f"/v1/jobs?{query}"))
    yield "unknown kind", lambda: raw(port, request("POST", "/v1/nokind/jobs", b"{}"))
    yield "job id not a UUID", lambda: raw(port, request("GET", "/v1/jobs/..%2F..%2Fetc"))

    def traversal() -> bytes:
        job = httpx.post(base + submit, content=meter, headers={"Content-Type": "application/json"}).json()["id"]
        outcome(base, job)
        answers = {raw(port, request("GET", f"/v1/jobs/{job}/artifacts/{name}")).split(b"\r\n", 1)[0]
                   for name in ("..%2F..%2Fplantsolve.db", "%2e%2e%2fplantsolve.db", "..%5C..%5Cplantsolve.db",
                                "%2Fetc%2Fpasswd")}
        return b" / ".join(sorted(answers)) + b"\r\ncontent-type: application/problem+json\r\n\r\n"
    yield "artifact names ../, %2e%2e, \\, /etc", traversal
    yield "client leaves mid-body", lambda: raw(
        port, request("POST", submit, meter[:20], length=len(meter)), half_close=True, timeout=30)


def run_http(label: str, port: int, bin_dir: Path) -> tuple[dict[str, tuple[str, bool, float, int]], int]:
    """Every HTTP-level case against a server started from ``bin_dir``; and the tracebacks in its log."""
    base = f"http://127.0.0.1:{port}"
    rows = {}
    with tempfile.TemporaryDirectory(prefix="plantsolve-hostile-http-") as data_dir:
        log_path = Path(data_dir) / "server.log"
        server = start(port, data_dir, log_path, bin_dir, BODY_IDLE_SECONDS=str(HTTP_IDLE_SECONDS))
        try:  # the server never outlives its data directory, whatever a case raises
            time.sleep(3)
            baseline = rss(server.pid)
            print(f"[{label}] server idle RSS {baseline / 2**20:.0f} MiB", flush=True)
            for name, thunk in http_cases(base, port):
                with Peak(server.pid) as peak:
                    begin = time.monotonic()
                    answer = thunk()
                    seconds = time.monotonic() - begin
                head = answer.partition(b"\r\n\r\n")[0]
                status = head.split(b"\r\n", 1)[0].decode("latin-1").removeprefix("HTTP/1.1 ")
                rows[name] = (status, b"application/problem+json" in head.lower(), seconds, peak.server - baseline)
        finally:
            server.send_signal(signal.SIGTERM)
            server.wait(timeout=60)
        tracebacks = log_path.read_text(errors="replace").count("Traceback")
    return rows, tracebacks


def main_http(args) -> int:
    runs = {"after": run_http("this checkout", args.port, BIN)}
    if args.before:
        runs["before"] = run_http(args.before, args.port + 1, Path(args.before).resolve() / ".venv" / "bin")
    order = [r for r in ("before", "after") if r in runs]
    print(f"\n{'case':40}" + "".join(f" | {r + ' status':>34} {'s':>6} {'MiB':>5}" for r in order))
    for name in runs["after"][0]:
        cells = ""
        for r in order:
            status, problem, seconds, growth = runs[r][0][name]
            cells += f" | {status[:32]:>32} {'P' if problem else ' '} {seconds:>6.2f} {growth / 2**20:>5.0f}"
        print(f"{name:40}{cells}")
    print("P: the answer is application/problem+json; MiB: the API process's peak RSS growth over its idle RSS")
    for r in order:
        print(f"tracebacks in the server log ({r}): {runs[r][1]}")
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--port", type=int, default=8765)
    parser.add_argument("--before", metavar="DIR", help="also run every case on the checkout in DIR (its .venv)")
    parser.add_argument("--http", action="store_true", help="the HTTP-level cases instead of the hostile files")
    args = parser.parse_args()
    if args.http:
        return main_http(args)
    runs = {"after": run("this checkout", args.port, BIN)}
    if args.before:
        runs["before"] = run(args.before, args.port + 1, Path(args.before).resolve() / ".venv" / "bin")
    order = [r for r in ("before", "after") if r in runs]
    head = "".join(f" | {r:>6} {'s':>5} {'API MiB':>7} {'tree MiB':>8} {'job':>17}" for r in order)
    print(f"\n{'case':38}{head}")
    for name in runs["after"]:
        cells = ""
        for r in order:
            status, seconds, growth, tree, crashed, ended = runs[r][name]
            mark = "*" if crashed else " "
            cells += f" | {status:>5}{mark} {seconds:>5.2f} {growth / 2**20:>7.0f} {tree / 2**20:>8.0f} {ended:>17}"
        print(f"{name:38}{cells}")
    print("* the server log says the reader failed on this file (a 422 that calls it malformed, naming no line)")
    print("job: how an accepted (202) job ended, with its warning count; the tree column includes the job process")
    for r in order:
        print(f"peak API process RSS growth across the cases ({r}): "
              f"{max(row[2] for row in runs[r].values()) / 2**20:.0f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
