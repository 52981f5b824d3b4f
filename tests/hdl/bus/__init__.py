"""Tests of the shared host interface."""
