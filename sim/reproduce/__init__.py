"""``k37 reproduce``: the paper's experiments on the emulator, one module each.

:mod:`~sim.reproduce.experiments` runs them all and writes the report. Beneath it:
:mod:`~sim.reproduce.paper` (the paper's numbers), :mod:`~sim.reproduce.theory` (the physics
they are compared with), :mod:`~sim.reproduce.runs` (scales and run specs),
:mod:`~sim.reproduce.workers` (the worker pool), :mod:`~sim.reproduce.markdown` (rows,
sections, ``report.md``), and one module per experiment: :mod:`~sim.reproduce.accel`,
:mod:`~sim.reproduce.rates`, :mod:`~sim.reproduce.fp_counts`,
:mod:`~sim.reproduce.path_error`, :mod:`~sim.reproduce.fp_control`,
:mod:`~sim.reproduce.budget`.
"""
