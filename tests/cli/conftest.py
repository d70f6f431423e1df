import pytest


@pytest.fixture
def serve_in_this_process(monkeypatch):
    """`cmd_serve` called in the test process: its heap is neither frozen (it would stay out of the collector's
    sight for the other tests) nor collected in full first — a server's start-up step, which in a worker holding the
    whole suite's modules is most of a call's CPU and which no test here checks."""
    from plantsolve import cli

    monkeypatch.setattr(cli.gc, "freeze", lambda: None)
    monkeypatch.setattr(cli.gc, "collect", lambda *args: 0)
