"""Poke the chipset's registers by name over the host bus, and watch the servo answer.

Loading the X K3702's error counter with 500 LSB is a position step: the D/A drives the
motor, the encoder's counts take the error back to zero, as in the paper's closed loop.

    python examples/api_registers.py
"""

from k37.sim import api

with api.Machine() as m:  # the demo's machine: the paper's chipset and servos
    print("chips:", ", ".join(m.chips()))
    m.write("K3702_X", "ALARM_ZONE", 2500)
    assert m.read("K3702_X", "ALARM_ZONE") == 2500

    m.write("K3702_X", "ERROR", 500)  # a 500 LSB step of the X position loop
    m.step(10)
    print(f"error {m.read('K3702_X', 'ERROR')} LSB, D/A word {m.get('x__dac'):#x}, "
          f"status {m.status('K3702_X')}")
    assert m.get("x__dac") > 1 << 11  # positive drive: above the 12-bit D/A's zero

    m.step(200_000)  # 0.2 s at 1 MHz
    error, moved = m.read("K3702_X", "ERROR"), m.get("x__count")
    print(f"after {m.cycle:,} cycles: error {error} LSB, the motor moved {moved} LSB")
    assert abs(error) <= 2 and abs(moved - 500) <= 2
    assert m.status("K3702_X")["in_position"] == 1
