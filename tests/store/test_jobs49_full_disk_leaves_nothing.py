"""A disk that fills while an upload is stored leaves nothing of it behind, on every failure path (mid-write, at the
close, at the rename): no temporary file, no folder made for it; and the submission is a 503 naming disk space."""

from __future__ import annotations

import errno
import os

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.store import blobs
from plantsolve.store.blobs import LocalBlobStore
from tests.conftest import REPO, service_settings

FULL = OSError(errno.ENOSPC, "No space left on device")
_fdopen, _replace = os.fdopen, os.replace


class _FillingFile:
    """A file whose disk fills: half of a write lands, then ENOSPC (``at="write"``) or ENOSPC at its close
    (``at="close"``)."""

    def __init__(self, handle, at: str):
        self.handle, self.at = handle, at

    def write(self, data):
        self.handle.write(data[: len(data) // 2])
        self.handle.flush()
        if self.at == "write":
            raise FULL
        return len(data)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.handle.close()
        if self.at == "close" and exc[0] is None:
            raise FULL


def _full_disk(monkeypatch, at: str) -> None:
    if at == "rename":
        def replace(src, dst):
            raise FULL
        monkeypatch.setattr(blobs.os, "replace", replace)
    else:
        monkeypatch.setattr(blobs.os, "fdopen", lambda fd, *a, **k: _FillingFile(_fdopen(fd, *a, **k), at))


def _left(root) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


@pytest.mark.parametrize("at", ["write", "close", "rename"])
def test_a_put_that_meets_a_full_disk_leaves_nothing(tmp_path, monkeypatch, at):
    store = LocalBlobStore(tmp_path)
    store.put("kept/a.bin", b"x")
    _full_disk(monkeypatch, at)
    with pytest.raises(OSError) as raised:
        store.put("job-1/input/scan.xyz", b"0123456789" * 1000)
    assert raised.value.errno == errno.ENOSPC
    with pytest.raises(OSError):
        store.put("kept/b.bin", b"y" * 100)
    assert _left(tmp_path) == ["kept", "kept/a.bin"]  # a folder that was there stays


@pytest.mark.parametrize("at", ["write", "close", "rename"])
def test_an_upload_on_a_full_disk_is_a_503_naming_disk_space_and_keeps_nothing(tmp_path, monkeypatch, at):
    scan = (REPO / "examples" / "tube" / "scan.xyz").read_bytes()
    with TestClient(create_app(service_settings(tmp_path)), raise_server_exceptions=False) as client:
        before = _left(tmp_path / "artifacts")
        _full_disk(monkeypatch, at)
        response = client.post("/v1/tube/jobs", files={"file": ("scan.xyz", scan)})
        monkeypatch.undo()
        assert response.status_code == 503, response.text
        assert response.json()["type"].endswith("/disk-space-low") and "disk is full" in response.json()["detail"]
        assert response.headers["retry-after"] == "60"
        assert _left(tmp_path / "artifacts") == before
        assert client.get("/v1/jobs").json()["items"] == []


def test_a_refused_upload_leaves_no_folder_behind(tmp_path):
    """A 422 (the reader refuses the file) deletes the stored upload and the folders it was stored in: each refusal
    would otherwise leave its ``<job id>/input`` folder, one more for every bad file sent."""
    with TestClient(create_app(service_settings(tmp_path))) as client:
        before = _left(tmp_path / "artifacts")
        for _ in range(3):
            assert client.post("/v1/tube/jobs", files={"file": ("scan.xyz", b"not a scan\n")}).status_code == 422
        assert _left(tmp_path / "artifacts") == before


def test_deleting_a_blob_keeps_folders_that_hold_others(tmp_path):
    store = LocalBlobStore(tmp_path)
    store.put("job/input/a.xyz", b"a")
    store.put("job/a1/plot.png", b"p")
    store.delete("job/input/a.xyz")
    assert _left(tmp_path) == ["job", "job/a1", "job/a1/plot.png"]
    store.delete("job/a1/plot.png")
    store.delete("job/a1/plot.png")  # a missing blob is no error
    assert _left(tmp_path) == []
    store.put("job/input/b.xyz", b"b")  # a folder pruned is made again
    assert store.get("job/input/b.xyz") == b"b"
