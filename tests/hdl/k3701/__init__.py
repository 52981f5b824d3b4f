"""Tests of the K3701 interpolator."""
