"""Sampling a run: the traced ports, at every multiple of ``sample_every`` cycles, streamed to a
temporary file as they are taken.

A run of 10^9 cycles sampled every cycle would not fit in memory: :class:`SampleStore` keeps the
samples on disk (80 bytes each, raw integers) and hands them back in chunks, so that what a run
holds in memory stays flat in its length. :class:`Sampler` takes them and stops the backend at
regular ticks (every :data:`PROGRESS_CYCLES` cycles at most), where the run's owner looks at
progress, limits and stop requests.
"""

from __future__ import annotations

import os
import tempfile
import weakref
from collections.abc import Callable, Iterator, Sequence

import numpy as np

from k37.hdl.chipset.map import AXES
from k37.sim.backends.contract import Backend
from k37.sim.machine.plant_model import DAC_VOLTS

__all__ = ["CHUNK_ROWS", "PROGRESS_CYCLES", "SAMPLED_PORTS", "TRACE_COLUMNS", "SampleStore",
           "Sampler", "sampled_ports", "trace_columns"]

#: Each sampled quantity: its trace column (after the axis name) and its port.
_QUANTITIES = (("command", "command"), ("actual", "count"), ("error", "error"),
               ("dac_volts", "dac"))


def trace_columns(axes: tuple[str, ...] = AXES) -> tuple[str, ...]:
    """Columns of the trace (CSV) and of :attr:`k37.sim.run.runner.RunResult.samples` on a
    machine with ``axes``: the cycle, each quantity per axis, the FP total."""
    return ("cycle", *(f"{a}_{column}" for column, _ in _QUANTITIES for a in axes), "fp_total")


def sampled_ports(axes: tuple[str, ...] = AXES) -> tuple[str, ...]:
    """The ports behind :func:`trace_columns` (after "cycle"; the D/A words become volts)."""
    return (*(f"{a}__{port}" for _, port in _QUANTITIES for a in axes), "fp_total")


#: The two-axis machine's columns and ports.
TRACE_COLUMNS = trace_columns()
SAMPLED_PORTS = sampled_ports()
#: Samples held in memory at a time, on the way in and on the way out.
CHUNK_ROWS = 1 << 16
#: The longest a backend that records the samples itself runs between ticks (cycles).
PROGRESS_CYCLES = 1_000_000
#: The same for a backend sampled from Python (Amaranth's simulator, thousands of times slower).
SLOW_TICK_CYCLES = 10_000
NEVER = 1 << 63

class SampleStore:
    """Samples appended as raw rows (the cycle and :attr:`ports`, integers) to an anonymous
    temporary file, read back as rows of :attr:`columns` (D/A words in volts for a
    ``dac_bits`` D/A converter), for a machine with ``axes``."""

    def __init__(self, dac_bits: int, axes: tuple[str, ...] = AXES):
        self._file = tempfile.TemporaryFile()  # noqa: SIM115 (open as long as the store)
        self._closer = weakref.finalize(self, self._file.close)  # deleted with the store
        self._half = 1 << (dac_bits - 1)
        #: The columns of a row, and the ports sampled for them.
        self.columns = trace_columns(axes)
        self.ports = sampled_ports(axes)
        self._width = len(self.columns)
        self._volts = [k for k, name in enumerate(self.columns) if name.endswith("_volts")]
        #: Samples stored.
        self.rows = 0

    def append(self, raw: np.ndarray) -> None:
        """Store ``raw``: integer rows of the cycle and :attr:`ports`."""
        if len(raw):
            self._file.seek(0, os.SEEK_END)
            self._file.write(np.ascontiguousarray(raw, dtype=np.int64).data)
            self.rows += len(raw)

    def raw(self, start: int, stop: int) -> np.ndarray:
        """Samples ``start`` to ``stop`` (exclusive) as stored: integer rows of the cycle and
        :attr:`ports` (read-only; the D/A words as codes)."""
        start, stop = max(0, start), min(stop, self.rows)
        self._file.seek(start * 8 * self._width)
        data = self._file.read(max(0, stop - start) * 8 * self._width)
        return np.frombuffer(data, dtype=np.int64).reshape(-1, self._width)

    def read(self, start: int, stop: int) -> np.ndarray:
        """Samples ``start`` to ``stop`` (exclusive), a row of :attr:`columns` each."""
        samples = self.raw(start, stop).astype(float)
        volts = self._volts
        samples[:, volts] = DAC_VOLTS * (samples[:, volts] - self._half) / self._half
        return samples

    def chunks(self, rows: int = CHUNK_ROWS) -> Iterator[np.ndarray]:
        """Every sample, in order, ``rows`` at a time."""
        for start in range(0, self.rows, rows):
            yield self.read(start, start + rows)

    def array(self) -> np.ndarray:
        """Every sample at once (memory in proportion to the run: for plots and tests)."""
        return self.read(0, self.rows)

    def close(self) -> None:
        """Delete the file now."""
        self._closer()


class Sampler:
    """Wraps a backend so that it is sampled at every multiple of ``every`` cycles into
    ``store``, and calls ``tick`` at regular points of the run.

    It offers the backend calls the firmware's host uses (``step``, ``run_until``, ``get``,
    ``bus_write``, ``bus_read``, ``cycle``). A backend that records (:meth:`Backend.record`,
    the compiled one) samples as it steps, without a call per sample, and its samples are
    taken into the store at each tick; with another, the sampler advances it in chunks that
    stop at every sample point and samples there. The samples are the same either way, on
    every backend alike. Ticks come every :data:`PROGRESS_CYCLES` cycles at most (fewer with
    a short sampling period, so that at most :data:`CHUNK_ROWS` samples wait in the
    recorder; :data:`SLOW_TICK_CYCLES` on a backend sampled from Python); ``tick`` may raise
    to end the run there. ``skip_idle`` is passed on to the backend's ``step`` and
    ``run_until``.
    """

    def __init__(self, backend: Backend, every: int, store: SampleStore, *,
                 skip_idle: bool = False, tick: Callable[[], None] | None = None):
        if every < 1:
            raise ValueError(f"sample_every must be >= 1 cycle, not {every}")
        self.backend = backend
        self.every = every
        self.store = store
        self.skip_idle = skip_idle
        self.tick = tick
        self.rows: list[list[int]] = []  # raw samples taken here: cycle and the ports
        self.native = backend.record(store.ports, every)
        self.tick_every = (min(PROGRESS_CYCLES, every * CHUNK_ROWS) if self.native
                           else SLOW_TICK_CYCLES)
        self.next_sample = NEVER if self.native else every
        self.next_tick = self.tick_every
        self.next = min(self.next_sample, self.next_tick)  # where calls stop

    @property
    def cycle(self) -> int:
        return self.backend.cycle

    def get(self, name: str) -> int:
        return self.backend.get(name)

    def flush(self) -> None:
        """Move the samples taken so far into the store."""
        if self.native:
            self.store.append(self.backend.recorded())
        elif self.rows:
            self.store.append(np.array(self.rows, dtype=np.int64))
            self.rows.clear()

    def _after(self) -> None:
        cycle = self.cycle
        if cycle < self.next:
            return
        if cycle >= self.next_sample:
            self.rows.append([cycle, *self.backend.get_many(self.store.ports)])
            self.next_sample += self.every
            if len(self.rows) >= CHUNK_ROWS:
                self.flush()
        ticked = cycle >= self.next_tick
        if ticked:
            self.next_tick += self.tick_every
        self.next = min(self.next_sample, self.next_tick)
        if ticked:
            if self.native:
                self.flush()
            if self.tick is not None:
                self.tick()

    def step(self, n: int = 1) -> None:
        while n > 0:
            k = min(n, self.next - self.cycle)
            self.backend.step(k, skip_idle=self.skip_idle)
            n -= k
            self._after()

    def run_until(self, port_name: str, max_cycles: int) -> int:
        done = 0
        while done < max_cycles:
            k = min(max_cycles - done, self.next - self.cycle)
            ran = self.backend.run_until(port_name, k, skip_idle=self.skip_idle)
            done += ran
            self._after()
            if ran < k or self.backend.get(port_name):
                break
        return done

    def wait_polling(self, max_cycles: int, period: int, ports: Sequence[int],
                     stops: Sequence[int], idles: Sequence[int],
                     due: bool) -> tuple[int, list[int] | None, int] | None:
        """The backend's :meth:`~k37.sim.backends.contract.Backend.wait_polling` on ``irq``, paused
        at the sampler's next tick; None where samples are taken from Python (each must be
        taken at its cycle) or the backend cannot."""
        if not self.native:
            return None
        result = self.backend.wait_polling("irq", max_cycles, self.next - self.cycle, period,
                                           ports, stops, idles, due=due,
                                           skip_idle=self.skip_idle)
        self._after()
        return result

    def bus_write(self, addr: int, data: int) -> None:
        self.backend.bus_write(addr, data)
        self._after()

    def bus_read(self, addr: int) -> int:
        value = self.backend.bus_read(addr)
        self._after()
        return value
