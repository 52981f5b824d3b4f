"""What a block tells a simulator about itself beyond its pins.

A block's signature holds its chip pins (and, for tests and the docs, its observation
outputs listed in its ``probes``, never exported as pins). Two more things only a simulator
needs, each block declares itself, in names local to the block:

* its **free-running state** (:class:`FreeRunning`): registers that run on by themselves
  between events (a phase divider, a counter of its strobes, an accumulator adding at each
  strobe, a countdown, a servo plant). While the block's ``quiet`` signal reads 1 that state
  affects nothing else until its next event, so a compiled simulator may skip the cycles up
  to that event and advance the state in closed form (exact idle skipping);
* its ``quiet`` signal itself, an attribute (``Signal``), not a port: a parent that uses it
  makes it one inside the design, and an exported chip never has it as a pin.

A parent composes its children's declarations with the submodule names it gives them
(:meth:`FreeRunning.under`, :meth:`FreeRunning.merge`); the simulation top's declaration then
names every register by its path below the top, which is what a backend resolves.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

__all__ = ["CarryAccumulator", "Countdown", "FreeRunning", "Observed", "PhaseAccumulator",
           "PlantState", "StrobeCounter", "join"]


def join(scope: str, path: str) -> str:
    """``path`` below the submodule ``scope`` (an empty path is the submodule itself)."""
    return f"{scope}.{path}" if path else scope


@dataclass(frozen=True)
class PhaseAccumulator:
    """A :class:`k37.hdl.feed.divider.PhaseDivider` at ``path`` (``phase``, ``increment``, ``stb``
    below it): it adds ``increment`` to ``phase`` at every edge, for ever."""

    #: The signals below ``path`` a backend reads (and writes, of the registers).
    ITEMS = ("phase", "increment", "stb")

    path: str
    width: int

    def under(self, scope: str) -> PhaseAccumulator:
        return replace(self, path=join(scope, self.path))


@dataclass(frozen=True)
class StrobeCounter:
    """A :class:`k37.hdl.feed.rate_multiplier.RateMultiplier` at ``path`` (``count``, ``select``,
    ``word``): it counts the cycles in which the accumulator at ``clock``'s ``stb`` is high,
    and pulses in those that select a set bit of ``word``. While the signal ``gate`` reads 1
    its pulses matter, so a skip must stop before the next one (None: they never matter)."""

    #: The signals below ``path`` a backend reads (and writes, of the registers).
    ITEMS = ("count", "select", "word")

    path: str
    width: int
    clock: str
    gate: str | None = None

    def under(self, scope: str) -> StrobeCounter:
        return replace(self, path=join(scope, self.path), clock=join(scope, self.clock),
                       gate=None if self.gate is None else join(scope, self.gate))


@dataclass(frozen=True)
class CarryAccumulator:
    """An :class:`k37.hdl.accel.exponential.AccelDecel` at ``path`` (``y``, ``x``): at each cycle in
    which the accumulator at ``clock``'s ``stb`` is high, ``y += x`` in ``n`` bits; a carry
    out of them changes ``x`` and sends a pulse, so a skip must stop before the next carry.
    ``clock`` is None until the parent that wires the strobe says which accumulator it is."""

    #: The signals below ``path`` a backend reads (and writes, of the registers).
    ITEMS = ("y", "x")

    path: str
    n: int
    signed: bool
    clock: str | None = None

    def under(self, scope: str) -> CarryAccumulator:
        return replace(self, path=join(scope, self.path),
                       clock=None if self.clock is None else join(scope, self.clock))


@dataclass(frozen=True)
class Countdown:
    """A register at ``path`` that, while it is not 0, goes down by one each cycle; reaching
    ``stop`` is an event, so a skip must stop before it (the K3701's step latency count,
    whose step comes out at 1)."""

    path: str
    stop: int

    def under(self, scope: str) -> Countdown:
        return replace(self, path=join(scope, self.path))


@dataclass(frozen=True)
class PlantState:
    """A servo plant at ``path`` (``velocity``, ``before``, ``dac``, ``dac_zero``, ``gain``,
    ``alpha``, ``vmax``, ``stall``, and its update period's ``period``, ``phase`` and summed
    feedforward ``ff``): while the rest stands still it is stepped natively, bit for bit as
    its gateware, up to a change of its count. Its fixed-point format is part of the
    declaration, so a backend takes it from the plant itself."""

    #: The signals below ``path`` a backend reads (and writes, of the registers).
    ITEMS = ("velocity", "before", "dac", "dac_zero", "gain", "alpha", "vmax", "stall", "period",
             "phase", "ff")

    path: str
    vc_bits: int
    alpha_bits: int
    frac_bits: int

    def under(self, scope: str) -> PlantState:
        return replace(self, path=join(scope, self.path))


@dataclass(frozen=True)
class FreeRunning:
    """State of a design that runs on by itself, for exact idle skipping.

    When the signal ``quiet`` reads 1, this state must affect nothing else in the design until
    a carry accumulator's next carry, a strobe counter's next pulse through its open gate, a
    plant's next count or a countdown's stop; a backend that skips idle cycles then proves a
    fixed point of the rest from one cycle and advances this state, up to that event
    (:meth:`k37.sim.backends.contract.Backend.step` with ``skip_idle``). ``quiet`` None: the
    declaring block has no such signal (its parent provides one).
    """

    accumulators: tuple[PhaseAccumulator, ...] = ()
    counters: tuple[StrobeCounter, ...] = ()
    carries: tuple[CarryAccumulator, ...] = ()
    plants: tuple[PlantState, ...] = ()
    countdowns: tuple[Countdown, ...] = ()
    quiet: str | None = None

    def under(self, scope: str) -> FreeRunning:
        """The same state seen from the parent that names this block's instance ``scope``."""
        return FreeRunning(
            tuple(a.under(scope) for a in self.accumulators),
            tuple(c.under(scope) for c in self.counters),
            tuple(c.under(scope) for c in self.carries),
            tuple(p.under(scope) for p in self.plants),
            tuple(c.under(scope) for c in self.countdowns),
            None if self.quiet is None else join(scope, self.quiet))

    def merge(self, *others: FreeRunning, quiet: str | None = None) -> FreeRunning:
        """This state and ``others``' together, with the parent's ``quiet`` signal."""
        parts = (self, *others)
        return FreeRunning(
            tuple(a for p in parts for a in p.accumulators),
            tuple(c for p in parts for c in p.counters),
            tuple(c for p in parts for c in p.carries),
            tuple(s for p in parts for s in p.plants),
            tuple(c for p in parts for c in p.countdowns),
            quiet)

    def reads(self) -> tuple[str, ...]:
        """Paths of every signal a backend reads to advance this state or to decide a skip:
        each part's :attr:`ITEMS`, the counters' gates, the countdowns and ``quiet``."""
        return (*(f"{a.path}.{name}" for a in self.accumulators for name in a.ITEMS),
                *(f"{c.path}.{name}" for c in self.counters for name in c.ITEMS),
                *(c.gate for c in self.counters if c.gate is not None),
                *(f"{c.path}.{name}" for c in self.carries for name in c.ITEMS),
                *(f"{p.path}.{name}" for p in self.plants for name in p.ITEMS),
                *(c.path for c in self.countdowns),
                *(() if self.quiet is None else (self.quiet,)))

    def registers(self) -> tuple[str, ...]:
        """Paths of the registers that make up this state (all else is "the rest")."""
        return (*(f"{a.path}.{name}" for a in self.accumulators for name in ("phase", "stb")),
                *(f"{c.path}.{name}" for c in self.counters for name in ("count", "select")),
                *(f"{c.path}.y" for c in self.carries),
                *(c.path for c in self.countdowns),
                *(f"{p.path}.{name}" for p in self.plants for name in ("velocity", "before")))


class Observed:
    """A block that tells a simulator about itself beyond its pins, in one way: read-only
    properties of the instance, computed from its parameters.

    * :attr:`probes`: the names of its output members that are observation outputs, not pins
      of the chip (the Verilog export keeps them inside);
    * :attr:`free_running`: its free-running state, in names local to the block (None: none);
      where it names a ``quiet`` signal, that signal is the instance's attribute ``quiet``, made
      in its constructor.

    Where a parent declares its state before it builds a child (in its ``elaborate``), the
    child's class computes the same declaration from its parameters alone, with a static
    ``declare``, which its ``free_running`` returns for its own parameters.

    A backend reads both of the simulation's top; a parent composes its children's.
    """

    @property
    def probes(self) -> tuple[str, ...]:
        """Observation outputs, not pins of the chip (the Verilog export keeps them inside)."""
        return ()

    @property
    def free_running(self) -> FreeRunning | None:
        """The free-running state, in names local to the block (None: none)."""
        return None
