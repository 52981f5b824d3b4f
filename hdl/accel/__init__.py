"""The accel/decel circuits: exponential (up/down counter + accumulator), linear and
bell-shaped; their reference models are in :mod:`k37.hdl.accel.model`.
"""
