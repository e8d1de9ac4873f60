"""The test suite's own set-up: under pytest-xdist (`-n auto --dist loadgroup`, pyproject.toml)
a test marked with an xdist_group (conftest.py marks those of a costly fixture) is sent to
its group's worker."""

import os

import pytest
from conftest import COSTLY_FIXTURES


@pytest.mark.xdist_group("grouping_check")
def test_a_grouped_test_is_sent_to_its_groups_worker(request):
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        pytest.skip("not run by pytest-xdist workers")
    # The loadgroup scheduler groups by the name after "@" in the node id; pytest 9.2 with
    # pytest-xdist 3.8 leaves it out, and every test goes to any worker.
    assert request.node.nodeid.endswith("@grouping_check"), request.node.nodeid


def test_the_tests_of_a_costly_fixture_are_grouped_by_it(request):
    # conftest.py marks them; its hook must run before pytest-xdist's reads the marks.
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        pytest.skip("not run by pytest-xdist workers")
    users = {
        item.nodeid: next(name for name in COSTLY_FIXTURES if name in item.fixturenames)
        for item in request.session.items
        if set(COSTLY_FIXTURES) & set(getattr(item, "fixturenames", ()))
    }
    if not users:
        pytest.skip("no test of a costly fixture was collected")
    assert all(nodeid.endswith(f"@{name}") for nodeid, name in users.items()), users
