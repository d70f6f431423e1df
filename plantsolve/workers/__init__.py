"""The queue side: the one runner function shared by the embedded pool and the Celery
workers, the dispatchers that carry job ids to it, and the sweeper.

Imports the store, the solvers (through the kind map) and the schemas; imported by ``app`` and
the CLI, never the other way.
"""
