"""The G-code language: the built-in front end (:mod:`k37.firmware_model.gcode.parser`, its
lexer, expressions, RS-274/NGC parameters and O-words, word table and modal interpreter) and
LinuxCNC's ``rs274`` (:mod:`k37.firmware_model.gcode.canon`). Both drive the motion planner of
:mod:`k37.firmware_model.motion`, which plans the moves into K3701 blocks.
"""
