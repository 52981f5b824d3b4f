"""The simulated machine: the chipset with a servo plant per axis (what every backend runs),
and a job's servo settings as the plants' parameters (:mod:`k37.sim.machine.servo`)."""
