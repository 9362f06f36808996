"""`driver compare compare.yaml` (issue 13, point 3; SPEC 3): both models calibrated to one
material, run over one grid of the same test, and put side by side.

- schema.py: the compare file (material or calibration.json, test, grid, resolutions).
- params.py: each model's parameters at every G_c of the grid (one calibration, reused).
- runs.py: the run configs of both models, run through the sweep machinery (resuming,
  failures recorded).
- stats.py: pure functions: the tidy table's common measures, the per-point side-by-side table
  (means, standard deviations, the difference in combined standard errors), the crossovers.
- plots.py, report.py: both models on the same axes; the report in words from the table.
"""
