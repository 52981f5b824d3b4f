"""The chipset: the chips on one 8085 bus (:mod:`hdl.chipset.chip`) and its chip selects
(:mod:`hdl.chipset.map`).
"""
