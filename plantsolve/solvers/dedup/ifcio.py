"""Reading the uploaded model: bytes (upload) or base64 (JSON) → a temporary ``.ifc`` file on disk →
``ifcopenshell.open``. Bad input (not a STEP file, truncated, unknown schema, a zip without an .ifc) is
refused with a 422 naming the file."""

from __future__ import annotations

import base64
import binascii
import io
import os
import tempfile
import zipfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import ifcopenshell

from plantsolve.schemas.dedup import DedupRequest
from plantsolve.solvers.base import reject


def request_bytes(request: DedupRequest) -> bytes:
    """The file's bytes (an upload's as received, or the JSON's ``file`` decoded)."""
    if request._content is not None:
        return request._content
    if request.file is None:
        raise reject("no file: send the IFC file as a multipart upload, or base64 in 'file'", ("file",))
    try:
        return base64.b64decode(request.file, validate=True)
    except (binascii.Error, ValueError):
        raise reject("'file' is not valid base64", ("file",)) from None


def step_text(content: bytes, filename: str) -> bytes:
    """The STEP text of an .ifc, or of the single .ifc inside an .ifczip."""
    if content[:4] == b"PK\x03\x04" or filename.lower().endswith(".ifczip"):
        try:
            with zipfile.ZipFile(io.BytesIO(content)) as archive:
                names = [n for n in archive.namelist() if n.lower().endswith(".ifc")]
                if len(names) != 1:
                    raise reject(f"an .ifczip must hold exactly one .ifc file; this one holds {len(names)}")
                content = archive.read(names[0])
        except zipfile.BadZipFile:
            raise reject("not a zip archive (an .ifczip is a zip holding one .ifc file)") from None
    check_header(content)
    return content


def check_header(content: bytes) -> None:
    head = content[:4096].lstrip(b"\xef\xbb\xbf \r\n\t")
    if not head.startswith(b"ISO-10303-21;"):
        raise reject("not an IFC file: a STEP physical file starts with 'ISO-10303-21;'")
    if b"FILE_SCHEMA" not in head.upper():
        raise reject("not an IFC file: no FILE_SCHEMA in the header")
    tail = content[-256:].rstrip()
    if not tail.endswith(b"END-ISO-10303-21;"):
        raise reject("truncated STEP file: it does not end with 'END-ISO-10303-21;'")


@contextmanager
def opened(request: DedupRequest) -> Iterator[tuple[ifcopenshell.file, int]]:
    """The model and the size of its STEP text in bytes; the text lives only in a temporary file."""
    text = step_text(request_bytes(request), request.filename)
    size = len(text)
    with tempfile.TemporaryDirectory(prefix="dedup-") as folder:
        path = Path(folder) / "input.ifc"
        path.write_bytes(text)
        del text
        yield open_path(str(path)), size


def open_path(path: str) -> ifcopenshell.file:
    try:
        model = ifcopenshell.open(path)
    except Exception as e:  # the parser raises several kinds for a broken file
        message = str(e) or type(e).__name__
        if "schema" in message.lower():
            raise reject(f"unknown or unsupported IFC schema: {message}") from None
        raise reject(f"unreadable IFC file: {message}") from None
    if model.schema not in ("IFC2X3", "IFC4") and not model.schema.startswith("IFC4X3"):
        raise reject(f"unsupported IFC schema {model.schema!r}; accepted: IFC2X3, IFC4, IFC4X3")
    return model


def write_bytes(model: ifcopenshell.file) -> bytes:
    fd, name = tempfile.mkstemp(suffix=".ifc", prefix="dedup-out-")
    os.close(fd)
    try:
        model.write(name)
        return Path(name).read_bytes()
    finally:
        Path(name).unlink(missing_ok=True)


class Reopened:
    """The written file read back from a temporary file (removed by ``close``)."""

    def __init__(self, content: bytes):
        fd, self.path = tempfile.mkstemp(suffix=".ifc", prefix="dedup-check-")
        with os.fdopen(fd, "wb") as handle:
            handle.write(content)
        self.model = ifcopenshell.open(self.path)

    def close(self) -> None:
        self.model = None
        Path(self.path).unlink(missing_ok=True)


def open_path_from_bytes(content: bytes) -> Reopened:
    return Reopened(content)
