"""The chipset on an FPGA board: clock enable, synchronisers, sigma-delta D/A and the pin map."""
