"""The feed chain ahead of the K3701: the phase divider, the binary rate multiplier, the FEED
chip that holds both, and the decel (FP budget) control.
"""
