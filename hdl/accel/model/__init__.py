"""The reference models of the accel/decel circuits in plain Python, one module per shape."""
