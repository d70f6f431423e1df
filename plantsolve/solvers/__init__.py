"""Pure numerics, one package per solver kind, each exporting ``SPEC`` (a
:class:`plantsolve.solvers.base.SolverSpec`); :mod:`plantsolve.solvers.kinds` lists them.

Every package uses the same file names for the same roles (``solve``, ``validation``,
``upload``, ``artifacts``, ``synthetic``); maths shared by kinds lives once in
:mod:`plantsolve.solvers.geometry`. Nothing here imports FastAPI, Celery or SQLAlchemy, and
nothing keeps global state.
"""
