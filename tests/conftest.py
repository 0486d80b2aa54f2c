"""Shared by every test: the registration the command line's entry points make,
and the hypothesis profiles.

Runs with a log record their inputs for ``maris log replay`` through the
recorder :mod:`mission.replay.record` registers when imported (the runtime does
not import the replay package, which is built on it).
"""

import os

from hypothesis import settings

import mission.replay.record  # noqa: F401 - registers the input record of run logs

# Property tests: `HYPOTHESIS_PROFILE=ci` (what .ci/run sets) runs each test's examples from a
# fixed seed, so a CI run is reproducible and a change is judged on the same examples as the
# last; `dev`, the default, draws new examples on every run and finds what the fixed ones miss
# (hypothesis replays a failure it found from its local database).
settings.register_profile("ci", derandomize=True, print_blob=True)
settings.register_profile("dev")
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "dev"))
