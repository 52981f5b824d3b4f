"""The accel/decel circuits: exponential (up/down counter + accumulator), linear and
bell-shaped, each beside its reference model.
"""
