"""Tests of studies: designs, study files, sweeps, analysis."""
