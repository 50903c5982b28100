"""Missions: loading mission files, checks and the metrics they measure, QGroundControl plans, spray jobs.

* :mod:`~vinecli.missions.spec_io` (mission files), :mod:`~vinecli.missions.quantities` (what a check may measure),
  :mod:`~vinecli.missions.checks` (checks on a finished run), :mod:`~vinecli.missions.rundata` (the run they read).
* :mod:`vinecli.missions.metrics` (metric families), :mod:`~vinecli.missions.deposition_metrics`,
  :mod:`~vinecli.missions.budget_metrics`, :mod:`~vinecli.missions.dose` (the dose judged by default),
  :mod:`~vinecli.missions.job` (whole-field spray jobs).
* :mod:`~vinecli.missions.qgc_format`, :mod:`~vinecli.missions.qgc_import`, :mod:`~vinecli.missions.qgc_export`
  (``.plan`` files); :mod:`~vinecli.missions.rowjob` (``vinecli plan rows``); :mod:`~vinecli.missions.patterns`.

May import every floor below it (the simulator's column names, the world, the spray models), not runs, report,
batch or the command line.
"""
