"""Hostile submissions against the real server: status, seconds and server RSS growth per case.

Starts ``plantsolve serve`` (embedded default, SQLite, a private data dir) on a loopback port with its output
in a file, sends each case at full size, and prints a table: case, status, seconds to answer, growth of the
API process's RSS over its idle baseline (peak sampled every 50 ms while the case runs) and of the whole
process tree (the forkserver and the bounded reading processes included). Last, SIGTERM during a hostile
parse: how long the server takes to exit.

    python bench/hostile.py [--port 8765]
"""

from __future__ import annotations

import argparse
import io
import os
import signal
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


def start(port: int, data_dir: str, log_path: Path) -> subprocess.Popen:
    env = {**os.environ, "DATA_DIR": data_dir, "API_KEYS": "", "EMBEDDED_WORKERS": "1"}
    log = open(log_path, "wb")
    server = subprocess.Popen([str(BIN / "plantsolve"), "serve", "--host", "127.0.0.1", "--port", str(port)],
                              stdout=log, stderr=subprocess.STDOUT, env=env)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1).status_code < 500:
                return server
        except httpx.HTTPError:
            time.sleep(0.3)
    raise SystemExit(f"the server did not start; see {log_path}")


def send(base: str, kind: str, body, headers, upload) -> tuple[int, float]:
    begin = time.monotonic()
    with httpx.Client(timeout=120) as client:
        if upload is not None:
            response = client.post(f"{base}/v1/{kind}/jobs", files={"file": upload})
        else:
            response = client.post(f"{base}/v1/{kind}/jobs", content=body, headers=headers)
    return response.status_code, time.monotonic() - begin


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--port", type=int, default=8765)
    args = parser.parse_args()
    base = f"http://127.0.0.1:{args.port}"
    with tempfile.TemporaryDirectory(prefix="plantsolve-hostile-") as data_dir:
        log_path = Path(data_dir) / "server.log"
        server = start(args.port, data_dir, log_path)
        time.sleep(5)  # the forkserver of the upload readers starts in the background
        baseline, tree_base = rss(server.pid), tree_rss(server.pid)
        print(f"server idle RSS {baseline / 2**20:.0f} MiB (tree {tree_base / 2**20:.0f} MiB); log: {log_path}")
        print(f"{'case':36} {'status':>6} {'seconds':>8} {'server RSS growth':>18} {'tree RSS growth':>16}")
        worst = 0
        for name, kind, body, headers, upload in cases():
            with Peak(server.pid) as peak:
                status, seconds = send(base, kind, body, headers, upload)
            growth, tree = peak.server - baseline, peak.tree - tree_base
            worst = max(worst, growth)
            print(f"{name:36} {status:>6} {seconds:>8.2f} {growth / 2**20:>14.0f} MiB {tree / 2**20:>12.0f} MiB",
                  flush=True)
        print(f"peak API process RSS growth across the cases: {worst / 2**20:.0f} MiB")
        # SIGTERM while a hostile upload is being read
        _, kind, body, headers, upload = next(c for c in cases() if c[0].startswith("64 MB"))
        sender = threading.Thread(target=lambda: send(base, kind, body, headers, upload), daemon=True)
        sender.start()
        time.sleep(0.5)
        begin = time.monotonic()
        server.send_signal(signal.SIGTERM)
        try:
            server.wait(timeout=30)
            print(f"SIGTERM during a hostile upload: the server exited after {time.monotonic() - begin:.2f} s")
        except subprocess.TimeoutExpired:
            print("SIGTERM during a hostile upload: the server did not exit within 30 s; killing it")
            server.kill()
            server.wait()
    return 0


if __name__ == "__main__":
    sys.exit(main())
