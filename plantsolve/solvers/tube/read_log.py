"""What a point-file reader left out, and why: skipped records with their line numbers and a file that ends early.

Readers keep what is usable and log the rest here, so that a job fed a damaged file succeeds with warnings
naming the lines, never as a clean success (and is refused only when nothing usable is left)."""

from __future__ import annotations

from collections import Counter

from plantsolve.schemas.common import Diagnostic

SHOW_LINES = 10  # line numbers listed in a warning; the count covers the rest


class ReadLog:
    """Skipped records (``skip``) and an early end of file (``truncate``) of one file being read."""

    def __init__(self, fmt: str):
        self.fmt = fmt
        self.lines: list[int] = []
        self.count = 0
        self.reasons: Counter[str] = Counter()
        self.truncation: Diagnostic | None = None
        self.notes: list[Diagnostic] = []

    def skip(self, line: int | None, reason: str, count: int = 1) -> None:
        """A record left out (``count`` records, for the same reason); ``line`` is its 1-based line number (None
        in binary files)."""
        if count <= 0:
            return
        self.count += count
        self.reasons[reason] += count
        if line is not None and len(self.lines) < SHOW_LINES:
            self.lines.append(line)

    def truncate(self, message: str, **details) -> None:
        """The file ends before what its header declares, or mid-record."""
        self.truncation = Diagnostic(code="file_truncated", message=f"{self.fmt.upper()} file: {message}",
                                     details=details)

    def warn(self, note: Diagnostic) -> None:
        """Something about the file as a whole that its reader noticed (read anyway)."""
        self.notes.append(note)

    def summary(self) -> str:
        """What was left out, for the refusal of a file with nothing usable left: '' when nothing was."""
        parts = [w.message for w in self.warnings()]
        return f" ({' '.join(parts)})" if parts else ""

    def warnings(self) -> list[Diagnostic]:
        out = ([self.truncation] if self.truncation else []) + self.notes
        if self.count:
            where = ""
            if self.lines:
                more = f" and {self.count - len(self.lines)} more" if self.count > len(self.lines) else ""
                where = f" (line{'s' if len(self.lines) > 1 else ''} {', '.join(map(str, self.lines))}{more})"
            reasons = "; ".join(f"{n} {r}" for r, n in self.reasons.most_common())
            out.append(Diagnostic(
                code="records_skipped",
                message=f"{self.count} record{'s' if self.count > 1 else ''} of the {self.fmt.upper()} file could not "
                f"be read and {'were' if self.count > 1 else 'was'} left out{where}: {reasons}.",
                details={"count": self.count, "lines": list(self.lines), "reasons": dict(self.reasons)}))
        return out
