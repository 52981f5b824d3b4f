"""What every block shares: parameter checks and limits (:mod:`hdl.common.params`) and what a
block tells a simulator beyond its pins (:mod:`hdl.common.observation`).
"""
