"""Synthesisable gateware of the K37 chipset, one hardware block per module.

Each block's plain-Python reference model sits beside it as ``<block>_model.py``.
"""
