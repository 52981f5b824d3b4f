"""Whole-machine tests: closed loops, the papers' physics, three axes, the command line."""
