"""Tests of the gateware and its reference models, one folder per chip."""
