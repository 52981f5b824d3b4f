"""Verilator for exported Verilog: lint, and a compiled model driven by pin name (the
independent cross-check of the export, not a job backend)."""
