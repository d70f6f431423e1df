"""Compressor performance maps from rig measurements (ESGI 51, HV-Turbo chapter).

Public API (the job service uses only these names):
``solve``, ``check_input``, ``parse_upload``, ``render_artifacts``, ``query``,
``UPLOAD_EXTENSIONS``, ``TIME_LIMITS``, ``__version__``.
"""

from solvers.perfmap.plots import render_artifacts
from solvers.perfmap.query import query
from solvers.perfmap.solve import solve
from solvers.perfmap.upload import UPLOAD_EXTENSIONS, parse_upload
from solvers.perfmap.validation import check_input

__version__ = "1.2.0"

# Typical runs take about a second (28 settings, 64x64 map); minimax with the log family and
# 1000x1000 maps take tens of seconds.
TIME_LIMITS = (120, 300)

__all__ = ["solve", "check_input", "parse_upload", "render_artifacts", "query",
           "UPLOAD_EXTENSIONS", "TIME_LIMITS", "__version__"]
