"""The KM3701 interpolator: the chip (:mod:`k37.hdl.k3701.chip`), its shared core, step latency and
datapaths, its register map and reference model.
"""
