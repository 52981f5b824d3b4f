"""Simulation backends behind one contract (``contract.py``): Amaranth's simulator, the compiled
CXXRTL model, and Verilator for exported Verilog; ``factory.py`` picks one by name."""
