"""plantsolve: engineering solvers for measured plant geometry and test-rig data, as a job service.

Five rooms, data flowing one way (see the README's architecture section):
``app`` (HTTP) → ``store`` (database, artifact files) ← ``workers`` (queue, runner) →
``solvers`` (pure numerics); ``schemas`` is the contract all of them share.
"""

__version__ = "0.1.0"
