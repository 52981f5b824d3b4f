(Written for K37's corpus in the style of a Fusion 360 post: a near-straight arc whose)
(centre offset is beyond the K3701's 24-bit registers, run as chords)
G90 G94 G17 G91.1
G21
G0 X0. Y0. Z5.
G1 Z-1. F500.
G2 X40. Y0.0217 I19.9937 J-9238.4701 F800.
G1 X40. Y10.
G2 X0. Y10.0217 I-20.0063 J9238.4592
G1 X0. Y0.
G0 Z5.
M30
