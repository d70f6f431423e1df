"""Bent-tube reconstruction from laser scans (issue 4).

Paper: "parametric reconstruction of bent tube surfaces" (MLS spine, G1 arc-line splines,
LRA). Stages: local polynomial fits (``local_fit``), MLS spine (``spine``), polygonal curve
(``curve``), arc-line spline (``arcline``), least-squares LRA fit (``fit``), inspection
against a nominal LRA (``inspection``); ``pipeline.solve`` runs them in order.
"""

from __future__ import annotations

from .artifacts import render_artifacts
from .pipeline import solve
from .pointio import UPLOAD_EXTENSIONS, parse_upload
from .validate import check_input

__version__ = "1.0.0"
TIME_LIMITS = (300, 900)

__all__ = ["solve", "check_input", "parse_upload", "render_artifacts", "UPLOAD_EXTENSIONS", "TIME_LIMITS",
           "__version__"]
