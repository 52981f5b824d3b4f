"""Tests of the FPGA flow: Verilog export, co-simulation, netlists, synthesis."""
