"""Simulation backends, plant models, waveform output and the ``k37`` command line."""
