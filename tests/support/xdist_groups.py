"""The integration tests on one pytest-xdist worker under ``--dist loadgroup`` (``make test``).

pytest-xdist groups the tests carrying an ``xdist_group`` mark by appending ``@<group>`` to their node ids on
each worker, and its scheduler sends every test whose id ends so to the same worker. It writes that suffix to
the item's ``_nodeid``; pytest 9.2 keeps a node's id in a structured ``_id`` instead, so the suffix is lost and
each grouped test is scheduled on its own, on whichever worker is free (nothing fails, nothing says so). Where
the suffix is missing after pytest-xdist's own step, it is written here into the id pytest reads."""

from __future__ import annotations

import pytest

GROUP = "integration"


def _groups(item: pytest.Item) -> list[str]:
    """The item's xdist_group names, as pytest-xdist reads them (a mark's first argument or its name=)."""
    return sorted({mark.args[0] if mark.args else mark.kwargs.get("name", "default")
                   for mark in item.iter_markers("xdist_group")})


def _suffixed(item: pytest.Item) -> bool:
    """Whether the id already ends in @<group> (after any parameters, which may contain an @ of their own)."""
    nodeid = item.nodeid
    return nodeid.rfind("@") > nodeid.rfind("]")


@pytest.hookimpl(wrapper=True)
def pytest_collection_modifyitems(config, items):
    """Before pytest-xdist's step: mark the integration tests as one group (they start Celery workers and servers
    of their own, and two such at once would only fight for the cores). After it: the suffix it could not write."""
    for item in items:
        if item.get_closest_marker("integration") is not None:
            item.add_marker(pytest.mark.xdist_group(GROUP))
    result = yield
    if getattr(config.option, "loadgroup", False):  # set on a pytest-xdist worker under --dist loadgroup
        from _pytest.nodeid import coerce_node_id

        for item in items:
            names = _groups(item)
            if names and not _suffixed(item):
                item._id = coerce_node_id(f"{item.nodeid}@{'_'.join(names)}")
    return result
