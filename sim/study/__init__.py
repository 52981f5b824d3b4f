"""Studies: designs of experiments over job keys and program parameters (``k37 sweep``), run
on a pool of workers into one table, and the ballbar analysis of circular runs."""
