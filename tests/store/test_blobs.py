"""The blob store's three back-ends behave alike: put/get/stream/delete round trips, a temporary local copy,
a missing key is BlobMissing (the API's 404) and an unreachable back-end BlobStoreUnavailable (its 503).
PostgreSQL runs against the test server (integration), S3 against moto's S3 server started here."""

from __future__ import annotations

import hashlib
import socket

import pytest

from plantsolve.store import Store, StoreSettings
from plantsolve.store.blobs import (
    CHUNK_BYTES,
    BlobMissing,
    BlobStoreUnavailable,
    LocalBlobStore,
    check_key,
)
from plantsolve.store.blobs_database import READ_SLICE_BYTES, DatabaseBlobStore
from plantsolve.store.blobs_s3 import S3BlobStore
from plantsolve.store.engine import Database
from tests.store.s3_server import moto_s3

# more than one HTTP chunk and more than one database slice, not a multiple of either
BIG = bytes(range(256)) * ((READ_SLICE_BYTES + CHUNK_BYTES + 12345) // 256)


@pytest.fixture(scope="module")
def s3_env():
    with moto_s3() as env:
        yield env


def _closed_port() -> int:
    with socket.socket() as probe:  # bound then released: nothing listens there
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture(params=["local", pytest.param("postgres", marks=pytest.mark.integration), "s3"])
def blobs(request, tmp_path):
    if request.param == "local":
        yield LocalBlobStore(tmp_path / "blobs")
    elif request.param == "postgres":
        db = Database(request.getfixturevalue("pg_url"))
        db.migrate()
        yield DatabaseBlobStore(db)
        db.dispose()
    else:
        env = request.getfixturevalue("s3_env")
        yield S3BlobStore(env["S3_BUCKET"], endpoint_url=env["S3_ENDPOINT_URL"])


def test_put_get_stream_delete_round_trip(blobs):
    key = "0b7e4f1c-job/a1/mesh stl.bin"
    stored = blobs.put(key, BIG)
    assert (stored.key, stored.size, stored.sha256) == (key, len(BIG), hashlib.sha256(BIG).hexdigest())
    assert blobs.exists(key) and blobs.get(key) == BIG
    reader = blobs.open(key)
    assert reader.size == len(BIG)
    chunks = list(reader.chunks())
    assert len(chunks) > 1 and all(len(c) <= max(CHUNK_BYTES, READ_SLICE_BYTES) for c in chunks)
    assert b"".join(chunks) == BIG
    blobs.put(key, b"replaced")  # a put replaces
    assert blobs.get(key) == b"replaced" and blobs.open(key).size == 8
    blobs.delete(key)
    assert not blobs.exists(key)
    with pytest.raises(BlobMissing):
        blobs.open(key)
    blobs.delete(key)  # deleting what is gone is no error


def test_empty_blob_round_trips(blobs):
    blobs.put("job/empty", b"")
    assert blobs.get("job/empty") == b"" and blobs.open("job/empty").size == 0


def test_missing_blob_is_blob_missing_not_an_os_error(blobs):
    """The API answers an OSError with 503 (the disk is away): a key that is simply not there must not be one."""
    with pytest.raises(BlobMissing) as raised:
        blobs.open("no-such-job/a1/plot.png")
    assert not isinstance(raised.value, OSError)
    assert not blobs.exists("no-such-job/a1/plot.png")


def test_local_file_holds_the_bytes_and_a_copy_is_removed_after(blobs):
    blobs.put("job/input/model.ifc", BIG)
    with blobs.local_file("job/input/model.ifc", "model.ifc") as path:
        assert path.read_bytes() == BIG and path.suffix == ".ifc"
    if not isinstance(blobs, LocalBlobStore):
        assert not path.exists()  # a temporary copy, gone with the block
    with pytest.raises(BlobMissing):
        with blobs.local_file("job/input/nothing.ifc"):
            pass


@pytest.mark.parametrize("key", ["../etc/passwd", "/abs/key", "job/../../x", "job//x", "job/./x", "a\\b", "job/\x00"])
def test_keys_that_could_escape_or_mislead_are_refused(key, tmp_path):
    with pytest.raises(ValueError):
        check_key(key)
    with pytest.raises(ValueError):
        LocalBlobStore(tmp_path).put(key, b"x")


def test_unreachable_s3_is_unavailable():
    blobs = S3BlobStore("bucket", endpoint_url=f"http://127.0.0.1:{_closed_port()}", connect_timeout=0.5)
    for call in (lambda: blobs.put("job/x", b"x"), lambda: blobs.open("job/x"), lambda: blobs.exists("job/x")):
        with pytest.raises(BlobStoreUnavailable):
            call()


def test_missing_bucket_is_unavailable_not_missing(s3_env):
    """A misconfigured bucket is the service's problem (503), not a missing file of the caller's (404)."""
    blobs = S3BlobStore("no-such-bucket-here", endpoint_url=s3_env["S3_ENDPOINT_URL"])
    with pytest.raises(BlobStoreUnavailable):
        blobs.put("job/x", b"x")


def test_unreachable_database_is_unavailable(tmp_path):
    db = Database(f"postgresql+psycopg://postgres@127.0.0.1:{_closed_port()}/nothing?connect_timeout=2")
    blobs = DatabaseBlobStore(db)
    try:
        for call in (lambda: blobs.put("job/x", b"x"), lambda: blobs.open("job/x"), lambda: blobs.exists("job/x")):
            with pytest.raises(BlobStoreUnavailable):
                call()
    finally:
        db.dispose()


def test_unwritable_local_folder_is_unavailable(tmp_path):
    (tmp_path / "file").write_text("not a folder")
    with pytest.raises(BlobStoreUnavailable):
        LocalBlobStore(tmp_path / "file").put("job/x", b"x")


@pytest.mark.parametrize("env, expected", [
    ({}, "local"),
    ({"DATABASE_URL": "postgresql+psycopg://u@h/db"}, "postgres"),
    ({"DATABASE_URL": "postgresql+psycopg://u@h/db", "BLOB_STORE": "local"}, "local"),
    ({"BLOB_STORE": "s3", "S3_BUCKET": "b"}, "s3"),
])
def test_blob_store_setting_and_its_default(env, expected, monkeypatch, tmp_path):
    for name in ("DATABASE_URL", "BLOB_STORE", "S3_BUCKET", "S3_ENDPOINT_URL"):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    assert StoreSettings(_env_file=None, data_dir=tmp_path).resolved_blob_store == expected


def test_store_opens_the_configured_back_end(tmp_path, s3_env):
    sqlite = StoreSettings(_env_file=None, data_dir=tmp_path)
    store = Store.open(sqlite, migrate=True)
    try:
        assert isinstance(store.files, LocalBlobStore) and store.files.root == tmp_path / "artifacts"
        assert store.spool is store.files
    finally:
        store.close()
    on_s3 = sqlite.model_copy(update={"blob_store": "s3", "s3_bucket": s3_env["S3_BUCKET"],
                                      "s3_endpoint_url": s3_env["S3_ENDPOINT_URL"]})
    store = Store.open(on_s3, migrate=True)
    try:
        assert isinstance(store.files, S3BlobStore) and isinstance(store.spool, LocalBlobStore)
        store.files.put("job/x", b"through the store")
        assert store.files.get("job/x") == b"through the store"
    finally:
        store.close()
    with pytest.raises(ValueError, match="S3_BUCKET"):
        Store.open(sqlite.model_copy(update={"blob_store": "s3"}))
