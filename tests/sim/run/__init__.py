"""Tests of a run: job files, plans, reports, plots, waveforms, run control."""
