"""Blobs in an S3-compatible bucket (``BLOB_STORE=s3``): AWS S3, MinIO, Ceph RGW, Garage … through boto3.

``S3_BUCKET`` names the bucket (it must exist), ``S3_ENDPOINT_URL`` the server when it is not AWS (then
path-style addressing, which every S3-compatible server understands), ``S3_REGION`` its region;
credentials come the usual boto3 way (``AWS_ACCESS_KEY_ID``/``AWS_SECRET_ACCESS_KEY``, a profile, an
instance role). A download streams the object's body in 1 MiB chunks.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

from plantsolve.store.blobs import CHUNK_BYTES, BlobMissing, BlobReader, BlobStore, BlobStoreUnavailable, StoredBlob, check_key, digest

_MISSING = {"NoSuchKey", "404", "NotFound"}


class S3BlobStore(BlobStore):
    kind = "s3"

    def __init__(self, bucket: str, *, endpoint_url: str | None = None, region: str | None = None,
                 connect_timeout: float = 5.0, read_timeout: float = 60.0):
        # imported here: boto3 belongs to the [scaled] extra, absent from the embedded default's install
        import boto3
        from botocore.config import Config

        self.bucket = bucket
        config = Config(connect_timeout=connect_timeout, read_timeout=read_timeout,
                        retries={"max_attempts": 3, "mode": "standard"},
                        s3={"addressing_style": "path"} if endpoint_url else None)
        self.client = boto3.session.Session().client("s3", endpoint_url=endpoint_url, region_name=region, config=config)

    def put(self, key: str, data: bytes) -> StoredBlob:
        stored = StoredBlob(check_key(key), len(data), digest(data))
        with _reachable(key):
            self.client.put_object(Bucket=self.bucket, Key=key, Body=bytes(data))
        return stored

    def open(self, key: str) -> BlobReader:
        with _reachable(check_key(key)):
            answer = self.client.get_object(Bucket=self.bucket, Key=key)
        body = answer["Body"]
        return BlobReader(int(answer["ContentLength"]), self._chunks(key, body), body.close)

    def exists(self, key: str) -> bool:
        try:
            with _reachable(check_key(key)):
                self.client.head_object(Bucket=self.bucket, Key=key)
        except BlobMissing:
            return False
        return True

    def delete(self, key: str) -> None:
        with _reachable(check_key(key)):
            self.client.delete_object(Bucket=self.bucket, Key=key)

    def keys(self, prefix: str) -> Iterator[str]:
        with _reachable(prefix):
            pages = self.client.get_paginator("list_objects_v2").paginate(Bucket=self.bucket, Prefix=prefix)
            found = [item["Key"] for page in pages for item in page.get("Contents", [])]
        return iter(found)

    @staticmethod
    def _chunks(key: str, body) -> Iterator[bytes]:
        with _reachable(key):
            yield from body.iter_chunks(CHUNK_BYTES)


@contextmanager
def _reachable(key: str) -> Iterator[None]:
    """A missing object is :class:`BlobMissing`; every other failure of the server or the way to it
    (connection, timeout, credentials, a missing bucket, a 5xx) is :class:`BlobStoreUnavailable`."""
    from botocore.exceptions import BotoCoreError, ClientError

    try:
        yield
    except ClientError as error:
        code = str(error.response.get("Error", {}).get("Code", ""))
        if code in _MISSING:
            raise BlobMissing(key) from None
        raise BlobStoreUnavailable(f"the S3 blob store refused the request: {code or error}") from error
    except BotoCoreError as error:
        raise BlobStoreUnavailable(f"the S3 blob store is unreachable: {type(error).__name__}") from error
