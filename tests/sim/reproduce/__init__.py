"""Tests of ``k37 reproduce``: the papers' experiments on the emulator."""
