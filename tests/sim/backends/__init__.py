"""Tests of the simulation backends (Amaranth's simulator, compiled CXXRTL)."""
