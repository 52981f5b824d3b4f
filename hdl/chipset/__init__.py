"""The chipset: the chips on one 8085 bus (:mod:`k37.hdl.chipset.chip`) and its chip selects
(:mod:`k37.hdl.chipset.map`).
"""
