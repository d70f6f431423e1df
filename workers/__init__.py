"""Job execution: the persistence layer for jobs and artifacts, the solver registry, the
one runner function shared by the embedded pool and the Celery workers, and the sweeper.

Imports ``solvers`` and ``schemas``; imported by ``app`` and the CLI, never the other way.
"""
