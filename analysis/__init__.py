"""Accuracy and cost: edgeaa against sample-based methods and real rasterizers.

- `sampling`: point sampling, ordered grids, rotated grid and 8-rooks coverage baselines.
- `peers`: Skia, AGG (aggdraw) and scikit-image's line_aa on the same edges, and the
  pixel-centre convention check.
- `evaluate`: every method on one common pixel set, against the exact area.
- `compare`: whole scenes drawn by every method beside edgeaa (`edgeaa render --compare`).
- `slope`: `edgeaa plot error-vs-slope`; `bench`: `edgeaa bench`; `stress`: `edgeaa stress`.
- `hardware`: the hook for cycles per column, LUTs and Fmax in the bench.
- `cli`: the commands `plot error-vs-slope`, `bench` and `stress` (registered on import).

Results and the commands that produced them: docs/results.md.
"""
