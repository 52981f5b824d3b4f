"""The 8085's 8-bit host bus: register-map descriptions (:mod:`hdl.bus.registers`), the bus
signature and register banks (:mod:`hdl.bus.hostbus`) and their model.
"""
