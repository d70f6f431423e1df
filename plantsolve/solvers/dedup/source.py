"""dedup's input value: the request and the IFC file it names, read where it lies.

An upload is opened straight from the service's stored file (no copy); an ``.ifczip`` is extracted
once, into a temporary folder that lives as long as the solve; a JSON request's base64 ``file`` is
decoded when first needed. Making the value never raises: the intake makes it before
``check_input``, whose 422s name the field."""

from __future__ import annotations

import base64
import binascii
import codecs
import io
import shutil
import tempfile
import zipfile
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import IO

from plantsolve.schemas.dedup import DedupOptions, DedupRequest
from plantsolve.solvers.base import StoredInput, reject
from plantsolve.solvers.dedup.ifcio import HEADER_BYTES, check_header
from plantsolve.solvers.step_file import TRAILER_BYTES

ZIP_MAGIC = b"PK\x03\x04"
SCHEMA_BYTES = 65536  # FILE_SCHEMA is looked for this far into the STEP text


def ends(stored: StoredInput, head: int, tail: int) -> tuple[bytes, bytes]:
    """The first ``head`` and last ``tail`` bytes of a stored file, without reading the rest of it."""
    if stored.path is None:
        content = stored.content
        return content[:head], content[max(len(content) - tail, 0):]
    with stored.path.open("rb") as handle:
        first = handle.read(head)
        handle.seek(max(stored.size - tail, 0))
        return first, handle.read()


def is_blank(stored: StoredInput) -> bool:
    """Empty or only white space (the whole file is read only when its start is blank)."""
    head, _ = ends(stored, HEADER_BYTES, 0)
    return not head.strip() and (stored.size <= len(head) or not stored.read().strip())


@dataclass(frozen=True)
class IfcSource:
    request: DedupRequest
    upload: StoredInput | None = None  # None: the file is the request's base64 ``file``

    @property
    def options(self) -> DedupOptions:
        return self.request.options

    @cached_property
    def stored(self) -> StoredInput:
        """The upload, or the JSON request's ``file`` decoded (a 422 on ``file`` when absent or not base64)."""
        if self.upload is not None and self.upload.extension != ".json":
            return self.upload  # an uploaded .json is the request: its model is the base64 in 'file'
        if self.request.file is None:
            raise reject("no file: send the IFC file as a multipart upload, or base64 in 'file'", ("file",))
        try:
            content = base64.b64decode(self.request.file, validate=True)
        except (binascii.Error, ValueError):
            raise reject("'file' is not valid base64", ("file",)) from None
        return StoredInput.from_bytes(self.request.filename, content)

    @property
    def zipped(self) -> bool:
        return self.stored.extension == ".ifczip" or ends(self.stored, len(ZIP_MAGIC), 0)[0] == ZIP_MAGIC

    def header(self) -> bytes:
        """The start of the STEP text (enough for FILE_SCHEMA), once the file proved to be a whole STEP file."""
        if not self.zipped:
            head, tail = ends(self.stored, SCHEMA_BYTES, TRAILER_BYTES)
            check_header(head[:HEADER_BYTES], tail)
            return head
        with self._member() as member:
            head = member.read(SCHEMA_BYTES)
            tail = head[-TRAILER_BYTES:]
            while chunk := member.read(1 << 20):  # the trailer: decompressed in passing, kept nowhere
                tail = (tail + chunk)[-TRAILER_BYTES:]
        check_header(head[:HEADER_BYTES], tail)
        return head

    @contextmanager
    def step_file(self) -> Iterator[tuple[Path, int]]:
        """A path to the STEP text on disk and its size in bytes: the stored ``.ifc`` itself, or a copy (removed
        when the block ends): the ``.ifc`` of an ``.ifczip`` extracted once, or the text after the UTF-8 byte-order
        mark an editor put before 'ISO-10303-21;' (IfcOpenShell's parser stops at it)."""
        if not self.zipped and ends(self.stored, len(codecs.BOM_UTF8), 0)[0] != codecs.BOM_UTF8:
            with self.stored.as_file() as path:
                yield path, self.stored.size
            return
        with tempfile.TemporaryDirectory(prefix="dedup-") as folder:
            path = Path(folder) / "input.ifc"
            with self.stream() as stream, path.open("wb") as out:
                out.write(stream.read(len(codecs.BOM_UTF8)).removeprefix(codecs.BOM_UTF8))
                shutil.copyfileobj(stream, out, 1 << 20)
            check_header(*ends(StoredInput.from_path(path), HEADER_BYTES, TRAILER_BYTES))
            yield path, path.stat().st_size

    @contextmanager
    def stream(self) -> Iterator[IO[bytes]]:
        """The STEP text as a stream: the ``.ifczip``'s member, or the stored file."""
        if self.zipped:
            with self._member() as member:
                yield member
        else:
            with self.stored.as_file() as path, path.open("rb") as handle:
                yield handle

    @contextmanager
    def _member(self) -> Iterator[IO[bytes]]:
        """The one ``.ifc`` inside the ``.ifczip``, as a stream."""
        stored = self.stored
        try:
            with zipfile.ZipFile(stored.path if stored.path is not None else io.BytesIO(stored.content)) as archive:
                names = [n for n in archive.namelist() if n.lower().endswith(".ifc") and not _mac_metadata(n)]
                if len(names) != 1:
                    raise reject(f"an .ifczip must hold exactly one .ifc file; this one holds {len(names)}"
                                 + (f" ({', '.join(map(repr, names[:5]))})" if names else ""))
                declared = archive.getinfo(names[0]).file_size
                if declared > MAX_IFC_INFLATED:
                    raise reject(f"the .ifc inside this .ifczip inflates to {declared:,} bytes; at most "
                                 f"{MAX_IFC_INFLATED:,} are read")
                with archive.open(names[0]) as member:
                    yield InflationCounter(member)
        except zipfile.BadZipFile as error:
            # parse_upload saw the 'PK' of a zip: an archive whose directory at the end is missing was cut short
            raise reject(f"the zip archive is damaged or cut short ({error}); an .ifczip is a zip holding one .ifc "
                         "file") from None
        except (zlib.error, EOFError) as error:  # the member's compressed bytes are corrupt or end early
            raise reject(f"the .ifc inside this .ifczip cannot be inflated: the archive is damaged or cut short "
                         f"({error})") from None


def _mac_metadata(name: str) -> bool:
    """Whether a zip member is the metadata macOS's Finder adds when it compresses a file: '__MACOSX/._model.ifc' (an
    AppleDouble resource fork, no model), which made a Mac's archive of one model hold 'two .ifc files'."""
    parts = name.split("/")
    return parts[0] == "__MACOSX" or parts[-1].startswith("._")


# the most an .ifczip's model may inflate to, counted on the inflated bytes as they come (a zip may lie
# about its sizes): a zip bomb stops here
MAX_IFC_INFLATED = 1 << 30


class InflationCounter(io.RawIOBase):
    """A zip member read with its inflated bytes counted: past :data:`MAX_IFC_INFLATED` a 422 on ``file``."""

    def __init__(self, member: IO[bytes]):
        self.member, self.count = member, 0

    def readable(self) -> bool:
        return True

    def read(self, size: int = -1) -> bytes:
        chunk = self.member.read(size if size is not None and size >= 0 else MAX_IFC_INFLATED + 1 - self.count)
        self.count += len(chunk)
        if self.count > MAX_IFC_INFLATED:
            raise reject(f"the .ifc inside this .ifczip inflates to more than {MAX_IFC_INFLATED:,} bytes, the most "
                         "that is read (a zip bomb?)")
        return chunk


def load(request: DedupRequest, upload: StoredInput | None = None) -> IfcSource:
    """SPEC's ``load``: the request and, for an upload, its stored file."""
    return IfcSource(request, upload)
