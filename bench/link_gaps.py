"""What a link keeps exact and what it does not: one job in process and over links to a simulated
board whose time includes a UART's (``k37 serve --uart``), as a markdown table.

    PYTHONPATH=. python bench/link_gaps.py

Each row: where the first block starts and the gaps between blocks, in cycles on the machine;
the run's end on the machine; whether every block's FP and step pulses and end command equal
the run in process; the axes' final encoder counts.
"""

from __future__ import annotations

import threading

from k37.firmware_model.gcode.parser import parse
from k37.firmware_model.job import Job, MachineConfig, ServoConfig
from k37.sim.run.linked import run_linked
from k37.sim.run.runner import RunOptions, run_job
from k37.sim.serve.server import SimulatedBoard

PROGRAM = """G21 G91 F600
G01 X0.4 Y0.2
G03 X0 Y0 I0.1 J0
G01 X-0.2 Y-0.3
G01 X0.1 Y0
M30"""

#: (row, line: cycles per bit and host turnaround in cycles at 1 MHz, or None)
LINKS = (("link, no line time", None), ("UART 125 kBd (8 cycles/bit)", (8, 0)),
         ("UART 125 kBd, host answers in 1 ms", (8, 1000)),
         ("UART 250 kBd (4 cycles/bit)", (4, 0)))


def _job() -> Job:
    machine = MachineConfig()
    program = parse(PROGRAM, source="<link gaps>", lsb_mm=machine.lsb_mm, sqrt2=machine.sqrt2,
                    axes=machine.axes)
    return Job("link gaps", machine, dict.fromkeys(machine.axis_names, ServoConfig()), program)


def _row(label: str, report: dict, here: dict) -> str:
    blocks = report["blocks"]
    cycles = (report["link"]["board_blocks"] if "link" in report
              else [[b["start_cycle"], b["end_cycle"]] for b in blocks])
    gaps = [cycles[k + 1][0] - cycles[k][1] for k in range(len(cycles) - 1)]
    end = report["link"]["board_cycle"] if "link" in report else report["cycles"]
    same = all((a["fp_pulses"], a["steps"], a["end_command"])
               == (b["fp_pulses"], b["steps"], b["end_command"])
               for a, b in zip(blocks, here["blocks"], strict=True))
    return (f"| {label} | {cycles[0][0]:,} | {', '.join(f'{g:,}' for g in gaps)} | {end:,} "
            f"| {'yes' if same else 'no'} | {report['end_point']['actual']} |")


def main() -> None:
    job = _job()
    here = run_job(job, RunOptions(backend="cxxrtl")).report
    print("| run | first block starts | gaps between blocks | run ends | pulses and end "
          "commands as in process | final encoder counts (LSB) |")
    print("|---|---|---|---|---|---|")
    print(_row("in process (the 8085)", here, here))
    for label, line in LINKS:
        board = SimulatedBoard(job, "cxxrtl", line=line)
        thread = threading.Thread(target=board.serve, args=(1,))
        thread.start()
        report = run_linked(job, RunOptions(), f"tcp://127.0.0.1:{board.port}").report
        thread.join()
        board.close()
        print(_row(label, report, here))


if __name__ == "__main__":
    main()
