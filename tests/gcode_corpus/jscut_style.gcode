; Written for K37's corpus in the style of jscut: a pocket, millimetres
G21         ; Set units to mm
G90         ; Absolute positioning
G1 Z2.5400 F2540      ; Move to clearance level

;
; Operation:    0
; Type:         Pocket
; Paths:        1
; Direction:    Conventional
; Cut Depth:    3.175
; Pass Depth:   1
; Plunge rate:  127
; Cut rate:     1016
;

; Path 0
; Rapid to initial position
G1 X10.0000 Y10.0000 F2540
G1 Z0.0000
; plunge
G1 Z-1.0000 F127
; cut
G1 X30.0000 Y10.0000 F1016
G1 X30.0000 Y25.0000
G1 X10.0000 Y25.0000
G1 X10.0000 Y10.0000
G1 X11.5000 Y11.5000
G1 X28.5000 Y11.5000
G1 X28.5000 Y23.5000
G1 X11.5000 Y23.5000
G1 X11.5000 Y11.5000
; plunge
G1 Z-2.0000 F127
; cut
G1 X30.0000 Y10.0000 F1016
G1 X30.0000 Y25.0000
G1 X10.0000 Y25.0000
G1 X10.0000 Y10.0000
G1 X11.5000 Y11.5000
G1 X28.5000 Y11.5000
G1 X28.5000 Y23.5000
G1 X11.5000 Y23.5000
G1 X11.5000 Y11.5000
; plunge
G1 Z-3.1750 F127
; cut
G1 X30.0000 Y10.0000 F1016
G1 X30.0000 Y25.0000
G1 X10.0000 Y25.0000
G1 X10.0000 Y10.0000
; Retract
G1 Z2.5400 F2540
M2
