"""Writes the dedup examples: a 3-ring world-coordinate tunnel (IFC4, shuffled vertex order and rotated
face loops; 24 segments in 8 classes) and the zoo of awkward cases (IFC2X3).

    .venv/bin/python examples/dedup/make_examples.py
"""

from pathlib import Path

from plantsolve.solvers.dedup.synthetic import build_model, tunnel_file, zoo_spec

HERE = Path(__file__).resolve().parent

if __name__ == "__main__":
    tunnel_file(3, "IFC4", shuffle=True, seed=7).write(str(HERE / "tunnel_3rings.ifc"))
    build_model(zoo_spec("IFC2X3")).write(str(HERE / "zoo_ifc2x3.ifc"))
    print("wrote", ", ".join(p.name for p in sorted(HERE.glob("*.ifc"))))
