"""The K3701's motion planning on the host side, apart from the G-code language (as LinuxCNC's
``tp/`` stands beside ``rs274ngc/``): the :class:`~k37.firmware_model.motion.planner.Planner`
both front ends of :mod:`k37.firmware_model.gcode` drive, the items of a
:class:`~k37.firmware_model.motion.program.Program`, the exact plans of arcs
(:mod:`~k37.firmware_model.motion.arcs`), the K3701's parabolas and exponentials
(:mod:`~k37.firmware_model.motion.curves`) and splines run as lines
(:mod:`~k37.firmware_model.motion.splines`). It knows nothing of the language it is driven from.
"""
