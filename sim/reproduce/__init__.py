"""``k37 reproduce``: the paper's experiments on the emulator, one module each.

:mod:`~k37.sim.reproduce.experiments` runs them all and writes the report. Beneath it:
:mod:`~k37.sim.reproduce.paper` (the paper's numbers), :mod:`~k37.sim.reproduce.theory` (the physics
they are compared with), :mod:`~k37.sim.reproduce.runs` (scales and run specs),
:mod:`~k37.sim.reproduce.workers` (the worker pool), :mod:`~k37.sim.reproduce.markdown` (rows,
sections, ``report.md``), and one module per experiment: :mod:`~k37.sim.reproduce.accel`,
:mod:`~k37.sim.reproduce.rates`, :mod:`~k37.sim.reproduce.fp_counts`,
:mod:`~k37.sim.reproduce.path_error`, :mod:`~k37.sim.reproduce.fp_control`,
:mod:`~k37.sim.reproduce.budget`.
"""
