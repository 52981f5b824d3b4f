; Written for K37's corpus in the style of a grbl test file: feeds above a slow machine's
; maximum (clamped to it, with a warning), I/J arcs, incremental moves
G21 G90 G94 G17
G0 X0 Y0 Z2
G1 Z-0.5 F9000
G1 X40 F15000
G2 X50 Y10 I0 J10 F10000
G1 Y40
G3 X40 Y50 I-10 J0
G1 X0
G91
G1 Y-10 F9000
G1 Y-10
G1 Y-10
G90
G1 X0 Y0
G0 Z2
M30
