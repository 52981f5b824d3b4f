"""The 8085's 8-bit host bus: register-map descriptions (:mod:`k37.hdl.bus.registers`), the bus
signature and register banks (:mod:`k37.hdl.bus.hostbus`) and their model.
"""
