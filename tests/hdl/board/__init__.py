"""Tests of the board's gateware."""
