"""The simulated machine: the chipset with a servo plant per axis (what every backend runs)."""
