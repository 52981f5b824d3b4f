"""Tests of the G-code front end."""
