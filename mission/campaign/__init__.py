"""Monte Carlo campaigns: many randomized runs of one mission, and their statistics.

A campaign is N headless runs of one mission on one simulator scenario, each
with its own seed derived from the campaign seed (so the same seed gives the
same table, whatever the worker scheduling). The modules, one job each:

* :mod:`.plan` - :class:`RunSpec` / :class:`CampaignPlan`, per-run seeds.
* :mod:`.overrides` - ``--set key=value`` parsing (YAML scalars, safe loader).
* :mod:`.records` - :class:`RunRecord` (outcome of one run), outcome names.
* :mod:`.single` - the one-run function executed by workers (calls
  ``mission.runtime.api.run_mission`` and classifies the result).
* :mod:`.cluster` - the Dask path of the executor (dead workers, reruns, checks).
* :mod:`.deadline` - the per-run wall-clock limit.
* :mod:`.testing` - stand-in run functions for executor tests.
* :mod:`.executor` - local process pool or a Dask cluster; never crashes on a
  failing run.
* :mod:`.stats` - Wilson 95 % interval, outcome counts.
* :mod:`.report` - text table, CSV, PNG chart.
* :mod:`.progress` - progress bar (TTY) or periodic plain lines.
* :mod:`.oscillation` - high-frequency RMS of joint reference velocities.
* :mod:`.paper` - the MARIS three-configuration experiment and docs/results.md.

Heavy imports (numpy, matplotlib, dask, the runtime) happen inside functions so
that ``maris --help`` stays fast.
"""
