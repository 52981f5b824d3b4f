"""What every block shares: parameter checks and limits (:mod:`k37.hdl.common.params`), the
constants of the whole chipset (:mod:`k37.hdl.common.constants`) and what a block tells a
simulator beyond its pins (:mod:`k37.hdl.common.observation`).
"""
