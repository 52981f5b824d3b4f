"""The reference models of the feed chain's blocks in plain Python, one module per block."""
