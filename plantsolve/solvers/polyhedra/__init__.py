"""Polyhedral measures on generalized maps: zone volumes, areas with holes, closure diagnostics.

Soto-Francés, Sarabia-Escrivá, Pinazo-Ojer: consistently oriented dart-based 3-D modelling by means
of geometric algebra and combinatorial maps. Stages: repair (merge, T-junctions, hole orientation)
→ generalized map (darts, α0..α3) → measures per orbit (Newell, divergence theorem in each zone's
frame) → diagnostics (open/non-manifold edges, orientation, Euler characteristic, genus) → adjacency.
"""
