"""The K3701's datapaths, one per interpolation type: linear, circular, helix (an arc's third
axis) and parabolic (parabolas and exponentials); their reference models are in
:mod:`k37.hdl.k3701.datapaths.model`.
"""
