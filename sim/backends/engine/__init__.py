"""The event-level engine: the default machine's chips and plants as compiled C++ (not RTL),
checked cycle by cycle against the compiled RTL backend (:mod:`.lockstep`)."""
