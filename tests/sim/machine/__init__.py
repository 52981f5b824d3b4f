"""Tests of the simulated machine's plants and drives."""
