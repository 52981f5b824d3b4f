"""Tests of the chipset on an SoC bus."""
