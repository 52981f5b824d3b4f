"""The G-code front ends and the planner: the built-in parser
(:mod:`k37.firmware_model.gcode.parser`, its lexer and word table), LinuxCNC's ``rs274``
(:mod:`k37.firmware_model.gcode.canon`), and the planning of lines, arcs and curves into K3701
blocks (:mod:`k37.firmware_model.gcode.program`).
"""
