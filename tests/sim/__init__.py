"""Tests of the simulation: its library API and generated documentation."""
