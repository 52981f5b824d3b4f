"""Verilog export of the chips with their pin names, and iCE40 synthesis reports."""
