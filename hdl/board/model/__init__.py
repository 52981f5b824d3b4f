"""The reference models of the board's blocks in plain Python (the sigma-delta D/A, the
watchdog and machine I/O)."""
