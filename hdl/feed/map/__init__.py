"""The feed chain's register maps as the host sees them, one module per block on the bus."""
