"""The simulated machine and its backends, the host's links to a chipset, running jobs, the FPGA
flow, reproducing the paper, and the ``k37`` command line (one sub-package each)."""
