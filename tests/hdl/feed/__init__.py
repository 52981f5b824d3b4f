"""Tests of the FEED and DECEL chips: divider, rate multiplier, feed rate, decel control."""
