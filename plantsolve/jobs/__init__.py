"""The job domain: everything a job is and goes through, without HTTP or a queue.

- :mod:`~plantsolve.jobs.lifecycle`: the statuses and the transitions between them;
- :mod:`~plantsolve.jobs.intake`: a submission read into the kind's input and checked, once;
- :mod:`~plantsolve.jobs.service`: submit, read, cancel, views (raises :mod:`~plantsolve.jobs.errors`);
- :mod:`~plantsolve.jobs.runner`: claim → heartbeat → solve → store, fenced on the attempt, with the
  retry policy and the reports;
- :mod:`~plantsolve.jobs.leases`: lapsed leases and lost messages;
- :mod:`~plantsolve.jobs.context`, :mod:`~plantsolve.jobs.settings`: what a process needs;
- :mod:`~plantsolve.jobs.dispatch`: the protocol every transport implements.

Imports the store, the solvers (through the kind map) and the schemas; imported by the app, the
transports in ``workers`` and the CLI.
"""
