"""What the register tables give as a read-only register's reset value is what it reads after
reset: on the simulated machine for the chipset's, on the model for the board's."""

from __future__ import annotations

from k37.firmware_model.job import MachineConfig
from k37.hdl.board.map import BOARD_MAP, board_port
from k37.hdl.board.model.machine_io import BusCycle, MachineIOModel
from k37.hdl.bus.registers import Access
from k37.sim.docs import chips
from k37.sim.run.runner import build_backend, configure_plants


def test_every_read_only_chip_register_reads_its_reset_value_on_the_machine_at_rest(make_job):
    job = make_job("G21 G91 F600\nG01 X1 Y1 Z1\nM30", MachineConfig(axes=3))
    backend = build_backend(job, "cxxrtl")
    try:
        backend.reset()
        configure_plants(backend, job)
        backend.step(100)
        seen = 0
        for chip in chips():
            if chip.regmap is BOARD_MAP:
                continue
            for reg in chip.regmap:
                if reg.access is Access.R:
                    value = sum(backend.bus_read(chip.base + reg.addr + k) << 8 * k
                                for k in range(reg.nbytes))
                    assert value == reg.reset, (chip.name, reg.name)
                    seen += 1
        assert seen == 9
    finally:
        backend.close()


def test_the_board_status_reads_its_reset_value_after_reset():
    model = MachineIOModel(3)
    model.step(BusCycle(board_port("STATUS"), r_stb=True))
    assert model.bank_r_data == BOARD_MAP["STATUS"].reset
