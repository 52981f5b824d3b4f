"""Tests of the encoder interface."""
