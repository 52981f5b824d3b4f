"""The chipset on an FPGA board: clock enable, synchronisers, sigma-delta D/A, the watchdog and
machine I/O (E-stop, limits, drive-enable) and the pin map."""
