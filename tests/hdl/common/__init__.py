"""Tests of what the blocks share: the simulation-only state they declare."""
