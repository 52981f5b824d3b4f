%
(Written for K37's corpus in the style of a Fusion 360 LinuxCNC post)
(T1  D=6. CR=0. - ZMIN=-2. - flat end mill)
G90 G94 G17 G91.1
G21
G28 G91 Z0.
G90

(2D Contour1)
T1 M6
S8000 M3
G54
M8
G0 X-3.5 Y-3.5
G43 Z15. H1
G0 Z5.
G1 Z1. F333.3
G1 Z-2.
G1 X-3. F1000.
G3 X0. Y-6.5 I3. J0.
G1 X40.
G3 X46.5 Y0. I0. J6.5
G1 Y30.
G3 X40. Y36.5 I-6.5 J0.
G1 X0.
G3 X-6.5 Y30. I0. J-6.5
G1 Y0.
G3 X0. Y-6.5 I6.5 J0.
G1 X0.3
G0 Z15.
M9
G28 G91 Z0.
G90
G49
M5
M30
%
