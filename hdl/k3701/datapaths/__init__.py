"""The K3701's datapaths, one per interpolation type, each beside its reference model: linear,
circular, helix (an arc's third axis) and parabolic (parabolas and exponentials).
"""
