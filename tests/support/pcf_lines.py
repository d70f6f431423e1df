"""A PCF line of a pipe, an elbow and a pipe, for the tests of how an elbow's records are read."""

from __future__ import annotations

import numpy as np


def elbow_line(theta: float, angle_record: str, radius: float = 1000.0, radius_record: float | None = None) -> str:
    """A pipe, an elbow of ``theta`` degrees on ``radius`` (its CENTRE-POINT the corner, arms R·tan(θ/2)) recorded
    ``ANGLE angle_record`` and ``BEND-RADIUS radius_record`` (default: ``radius``), and a pipe, in mm."""
    t = np.radians(theta)
    arm = radius * np.tan(t / 2)
    e0 = np.array([1000.0, 0, 0])
    corner = e0 + [arm, 0, 0]
    d = np.array([np.cos(t), np.sin(t), 0.0])
    e1 = corner + arm * d
    e2 = e1 + 1000 * d

    def f(p):
        return " ".join(f"{v:.4f}" for v in p)

    return (f"ISOGEN-FILES ISOGEN.FLS\nUNITS-BORE MM\nUNITS-CO-ORDS MM\nPIPELINE-REFERENCE TEST-1\n"
            f"PIPE\n    END-POINT {f([0, 0, 0])} 100.0000\n    END-POINT {f(e0)} 100.0000\n"
            f"ELBOW\n    END-POINT {f(e0)} 100.0000\n    END-POINT {f(e1)} 100.0000\n    CENTRE-POINT {f(corner)}\n"
            f"    ANGLE {angle_record}\n    BEND-RADIUS {radius if radius_record is None else radius_record:.4f}\n"
            f"PIPE\n    END-POINT {f(e1)} 100.0000\n    END-POINT {f(e2)} 100.0000\n")
