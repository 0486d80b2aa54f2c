"""One module per ``maris`` subcommand; see :mod:`mission.cli`."""
