"""The K3701's reference models in plain Python: the chip's interpolation algorithms and plans
(:mod:`k37.hdl.k3701.model.chip`) and its step latency count (:mod:`k37.hdl.k3701.model.latency`).
"""
