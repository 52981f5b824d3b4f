"""Sampling a run: the traced ports, at every multiple of ``sample_every`` cycles."""

from __future__ import annotations

import sys
import time

import numpy as np

from sim.backends.contract import Backend
from sim.machine.plant import DAC_VOLTS

__all__ = ["SAMPLED_PORTS", "TRACE_COLUMNS", "Sampler"]

#: Columns of the trace (CSV) and of :attr:`RunResult.samples`.
TRACE_COLUMNS = ("cycle", "x_command", "y_command", "x_actual", "y_actual", "x_error",
                 "y_error", "x_dac_volts", "y_dac_volts", "fp_total")
#: The ports behind those columns (after "cycle"; the D/A words become volts).
SAMPLED_PORTS = ("x__command", "y__command", "x__count", "y__count", "x__error", "y__error",
                 "x__dac", "y__dac", "fp_total")


#: With a backend that records the samples itself, calls stop only for the progress bar.
PROGRESS_CYCLES = 1_000_000
NEVER = 1 << 63


class Sampler:
    """Wraps a backend so that it is sampled at every multiple of ``every`` cycles.

    It offers the backend calls the firmware's host uses (``step``, ``run_until``, ``get``,
    ``bus_write``, ``bus_read``, ``cycle``). A backend that records (:meth:`Backend.record`,
    the compiled one) samples as it steps, without a call per sample; with another, the
    sampler advances it in chunks that stop at every sample point and samples there. The
    samples are the same either way, on every backend alike. ``skip_idle`` is passed on to
    the backend's ``step`` and ``run_until``.
    """

    def __init__(self, backend: Backend, every: int, dac_bits: int, progress_total: int = 0,
                 *, skip_idle: bool = False):
        if every < 1:
            raise ValueError(f"sample_every must be >= 1 cycle, not {every}")
        self.backend = backend
        self.rows: list[list[int]] = []  # raw samples taken here: cycle and SAMPLED_PORTS
        self.half = 1 << (dac_bits - 1)
        self.progress_total = progress_total
        self.skip_idle = skip_idle
        self._progress_at = 0.0
        self.native = backend.record(SAMPLED_PORTS, every)
        # Where calls stop: at each sample, or for the progress bar.
        self.stride = (every if not self.native else PROGRESS_CYCLES if progress_total
                       else NEVER)
        self.next = self.stride

    @property
    def cycle(self) -> int:
        return self.backend.cycle

    def get(self, name: str) -> int:
        return self.backend.get(name)

    def samples(self) -> np.ndarray:
        """The samples, a row of :data:`TRACE_COLUMNS` each (the D/A words in volts)."""
        raw = (self.backend.recorded() if self.native else
               np.array(self.rows, dtype=np.int64).reshape(-1, 1 + len(SAMPLED_PORTS)))
        data = raw.astype(float)
        volts = slice(TRACE_COLUMNS.index("x_dac_volts"), TRACE_COLUMNS.index("y_dac_volts") + 1)
        data[:, volts] = DAC_VOLTS * (data[:, volts] - self.half) / self.half
        return data

    def _progress(self) -> None:
        now = time.monotonic()
        if now - self._progress_at < 0.5:
            return
        self._progress_at = now
        frac = min(1.0, self.cycle / self.progress_total)
        bar = "#" * int(frac * 30)
        print(f"\rk37 run: [{bar:<30}] {self.cycle:,} cycles", end="", file=sys.stderr)

    def _after(self) -> None:
        if self.cycle >= self.next:
            if not self.native:
                self.rows.append([self.cycle, *self.backend.get_many(SAMPLED_PORTS)])
            self.next += self.stride
            if self.progress_total:
                self._progress()

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

    def bus_write(self, addr: int, data: int) -> None:
        self.backend.bus_write(addr, data)
        self._after()

    def bus_read(self, addr: int) -> int:
        value = self.backend.bus_read(addr)
        self._after()
        return value
