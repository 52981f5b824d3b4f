(Written for K37's corpus in the style of a UGS test file: inch, comments of both kinds)
G20 G90 ; inches
G0 X0 Y0 Z0.1
G1 Z-0.01 F10 ; plunge
G1 X1.0 Y0.0 F20
G1 X1.0 Y1.0
G2 X0.5 Y1.5 I-0.5 J0.0
G1 X0.0 Y1.5
G3 X0.0 Y0.5 I0.0 J-0.5
G1 X0 Y0
G0 Z0.1
N100 G0 X0.25 Y0.25
N110 G1 Z-0.02 F5
N120 G2 I0.25 J0 F15 (full circle)
N130 G0 Z0.1
M30
