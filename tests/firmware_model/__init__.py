"""Tests of the firmware model: the 8085 host and its feed words."""
