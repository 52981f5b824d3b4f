"""The host's links to a chipset, side by side: each implements
:class:`k37.firmware_model.link.ChipsetLink`, the interface the firmware drives. The simulated
machine's bus and interrupt ports in this process (:mod:`k37.sim.link.simulated`), or a board
behind the host bridge's protocol, simulated (``k37 serve``) or real (:mod:`k37.sim.link.bridge`).
"""
