"""Shared by every test: the registration the command line's entry points make,
the hypothesis profiles and the ``realtime`` marker's reach.

Runs with a log record their inputs for ``maris log replay`` through the
recorder :mod:`mission.replay.record` registers when imported (the runtime does
not import the replay package, which is built on it).
"""

import os
from pathlib import Path

import pytest
from hypothesis import settings

import mission.replay.record  # noqa: F401 - registers the input record of run logs

# Property tests: `HYPOTHESIS_PROFILE=ci` (what .ci/run sets) runs each test's examples from a
# fixed seed, so a CI run is reproducible and a change is judged on the same examples as the
# last; `dev`, the default, draws new examples on every run and finds what the fixed ones miss
# (hypothesis replays a failure it found from its local database).
settings.register_profile("ci", derandomize=True, print_blob=True)
settings.register_profile("dev")
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "dev"))


_HAL_TESTS = Path(__file__).parent / "hal"


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Every test under ``tests/hal`` (drivers on live streams, with their own threads and
    timeouts) and every ``peer`` or ``viewer`` test is also ``realtime``: ``make test`` runs
    the others on several processes first, then these alone, so that no other test takes the CPU
    from a peer's or a watchdog's timing. Every ``realtime`` test is in the xdist group
    ``realtime``: with ``--dist loadgroup`` (``make test-fast``) they run one after another
    on one process."""
    for item in items:
        if item.path.is_relative_to(_HAL_TESTS) or item.get_closest_marker("peer") or item.get_closest_marker("viewer"):
            item.add_marker(pytest.mark.realtime)
        if item.get_closest_marker("realtime"):
            item.add_marker(pytest.mark.xdist_group("realtime"))
