"""The event-level engine: the simulated machine's chips and plants as compiled C++ (not RTL),
checked cycle by cycle against the compiled RTL backend (:mod:`.lockstep`)."""
