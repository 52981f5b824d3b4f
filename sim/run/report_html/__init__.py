"""The ``--html`` report of a run: one self-contained page (plotly.js, its data, its script and
style inside it) with the part, the run's time series, the per-block table, the summary, the
job and the ballbar; and the page frame a study's report shares."""
