"""Tests of the KM3702 position controller."""
