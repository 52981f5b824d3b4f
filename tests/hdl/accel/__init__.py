"""Tests of the accel/decel circuits (exponential, linear, bell)."""
