; Written for K37's corpus in the style of a Universal G-code Sender test file: two jobs in
; one file; LinuxCNC (and K37) stop at the first M30 and ignore the rest
G21 G90
G0 X0 Y0 Z5
G1 Z-1 F200
G1 X25 F500
G1 Y25
G1 X0
G1 Y0
G0 Z5
M30
G21 G90
G0 X100 Y100 Z5
G1 Z-1 F200
G1 X125 F500
M30
