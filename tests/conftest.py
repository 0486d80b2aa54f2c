"""Shared by every test: the registration the command line's entry points make.

Runs with a log record their inputs for ``maris log replay`` through the
recorder :mod:`mission.replay.record` registers when imported (the runtime does
not import the replay package, which is built on it).
"""

import mission.replay.record  # noqa: F401 - registers the input record of run logs
