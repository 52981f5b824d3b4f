"""Tests of the host's contour controllers."""
