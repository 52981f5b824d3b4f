# amaranth: UnusedElaboratable=no
"""The compiled CXXRTL backend against Amaranth's simulator, bit for bit, on small designs.

The designs (``designs.py`` beside this file) are submodules of a :class:`Zoo`, so the module
builds two models (all blocks; and the blocks that keep CXXRTL on its fast paths), a few
seconds each, once per machine thanks to the cache, and shares them between tests.
"""

import random
import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from k37.hdl.common import observation
from k37.hdl.common.observation import FreeRunning
from k37.sim.backends.contract import Backend
from k37.sim.backends.cxxrtl.backend import CxxrtlBackend
from k37.sim.backends.factory import BACKENDS, make_backend
from k37.sim.backends.introspect import component_ports
from k37.sim.backends.pysim import PysimBackend
from tests.sim.backends.designs import MAP, Combinational, Zoo
from tests.testbench import simulate


def outputs(backend: Backend) -> dict[str, int]:
    return {name: backend.get(name) for name in sorted(backend.ports)}


def stable_names(names: list[str]) -> list[str]:
    """Names without Amaranth's ``$<n>`` suffix for colliding names (both ``chain`` and ``negc``
    have an ``en``), which is numbered differently when the design is prepared with its port
    list (RTLIL) and without (Amaranth's simulator)."""
    return [name for name in names if "$" not in name]


def renamed(names: list[str]) -> list[str]:
    """The names that :func:`stable_names` leaves out, without their suffix."""
    return sorted(name.split("$")[0] for name in names if "$" in name)


def probes(backend: Backend, names: list[str]) -> dict[str, int]:
    return {name: backend.probe(name) for name in names}


def port_values(port) -> st.SearchStrategy[int]:
    if port.signed:
        return st.integers(-(1 << (port.width - 1)), (1 << (port.width - 1)) - 1)
    return st.integers(0, (1 << port.width) - 1)


@pytest.mark.parametrize("zoo", ["backends", "simple", "peeking"])
@settings(derandomize=True, max_examples=40, deadline=None)
@given(data=st.data())
def test_random_stimulus_gives_identical_outputs_every_cycle(request, zoo, data):
    pysim, cxxrtl = request.getfixturevalue(zoo)
    for backend in (pysim, cxxrtl):
        backend.reset()
    inputs = st.fixed_dictionaries({name: port_values(port)
                                    for name, port in pysim.ports.items() if port.is_input})
    # Waits on a register (pulse) or on combinational outputs (zero, done), or plain steps.
    waits = st.sampled_from([None, "phase__pulse", "updown__zero", "seq__done"])
    ops = data.draw(st.lists(st.tuples(inputs, st.integers(1, 3), waits),
                             min_size=1, max_size=60))
    for values, cycles, wait_for in ops:
        for name, value in values.items():
            pysim.set(name, value)
            cxxrtl.set(name, value)
        assert outputs(cxxrtl) == outputs(pysim)  # combinational paths settle at once
        if wait_for:
            limit = 8 * cycles
            assert cxxrtl.run_until(wait_for, limit) == pysim.run_until(wait_for, limit)
        else:
            pysim.step(cycles)
            cxxrtl.step(cycles)
        assert cxxrtl.cycle == pysim.cycle
        assert outputs(cxxrtl) == outputs(pysim)
    names = stable_names(pysim.probe_names())
    assert probes(cxxrtl, names) == probes(pysim, names)


def test_pysim_backend_steps_like_an_async_testbench(pair):
    dut, rng = Zoo(), random.Random(3)
    ports = component_ports(dut)
    stimulus = [{name: rng.getrandbits(port.width) for name, (port, _) in ports.items()
                 if port.is_input and rng.random() < 0.5} for _ in range(60)]
    expected = []

    async def bench(ctx):
        for values in stimulus:
            for name, value in values.items():
                ctx.set(ports[name][1], ports[name][0].decode(value))
            await ctx.tick()
            expected.append({name: ctx.get(value) for name, (_, value) in ports.items()})

    simulate(dut, bench)
    for backend in pair:
        for values, after in zip(stimulus, expected, strict=True):
            for name, value in values.items():
                backend.set(name, value)
            backend.step()
            assert outputs(backend) == after


def test_every_signal_of_amaranths_simulator_can_be_probed_on_cxxrtl(pair):
    pysim, cxxrtl = pair
    assert "bank.regs.value_shadow" in pysim.probe_names()
    assert set(stable_names(pysim.probe_names())) <= set(cxxrtl.probe_names())
    # CXXRTL adds struct fields (seq.cfg.length), which Amaranth names but does not simulate.
    extra = set(stable_names(cxxrtl.probe_names())) - set(pysim.probe_names())
    assert {name.rsplit(".", 1)[-1] for name in extra} == {"length", "again"}
    assert renamed(pysim.probe_names()) == renamed(cxxrtl.probe_names())


def test_register_bank_commits_on_the_last_byte_and_reads_a_snapshot(pair):
    value, commits = MAP["VALUE"], MAP["COMMITS"]
    for backend in pair:
        for k, byte in enumerate(value.to_bytes(-123456)):
            backend.bus_write(value.addr + k, byte, bus="bank__bus")
            assert backend.get("bank__value") == (-123456 if k == value.nbytes - 1 else 0)
        assert backend.probe("bank.regs.value_shadow") == -123456 & 0xFFFF  # bytes 0, 1
        data = [backend.bus_read(value.addr + k, bus="bank__bus") for k in range(value.nbytes)]
        assert value.from_bytes(data) == -123456
        assert backend.bus_read(commits.addr, bus="bank__bus") == 1
        for k, byte in enumerate(MAP["SCALE"].to_bytes(0xBEEF)):
            backend.bus_write(MAP["SCALE"].addr + k, byte, bus="bank__bus")
        assert backend.get("bank__scale") == 0xBEEF
        backend.step()  # the count takes the commit at the end of the cycle after it
        assert backend.bus_read(commits.addr, bus="bank__bus") == 2
    assert pair[0].cycle == pair[1].cycle


def test_negedge_domain_counts_falling_edges_after_the_first_rising_edge(pair):
    for backend in pair:
        backend.set("negc__en", 1)
        backend.step(10)
        # The clock starts low: ten cycles hold ten rising and nine falling edges.
        assert (backend.get("negc__pos"), backend.get("negc__neg")) == (10, 9)
        assert backend.get("negc__total") == 19
        backend.set("negc__en", 0)  # set between steps: seen by the next falling edge
        backend.step()
        assert (backend.get("negc__pos"), backend.get("negc__neg")) == (10, 9)


def test_signed_ports_and_probes_read_sign_extended(pair):
    for backend in pair:
        backend.set("math__a", -2048)
        backend.set("math__b", 15)
        assert backend.get("math__prod") == -30720
        backend.step()
        assert backend.get("math__acc") == -30720
        assert backend.probe("math.acc") == -30720
        backend.set("math__a", 0xFFF)  # the unsigned reading of the same bits
        assert backend.get("math__a") == -1
        with pytest.raises(ValueError, match="port math__a: 4096 does not fit in 12 bit"):
            backend.set("math__a", 4096)


def test_ports_wider_than_64_bits_round_trip(pair):
    for backend in pair:
        backend.set("math__wide", (1 << 72) - 1)
        backend.step()
        assert backend.get("math__wide_next") == 0
        backend.set("math__wide", 1 << 70)
        backend.step()
        assert backend.get("math__wide_next") == (1 << 70) + 1


def test_24_bit_up_down_counter_wraps_both_ways_and_inputs_start_at_init(pair):
    for backend in pair:
        assert backend.get("updown__load_value") == 0x123456
        backend.set("updown__load_value", 0xFFFFFF)
        backend.set("updown__load", 1)
        backend.step()
        backend.set("updown__load", 0)
        backend.set("updown__up", 1)
        backend.step()
        assert (backend.get("updown__count"), backend.get("updown__zero")) == (0, 1)
        backend.set("updown__up", 0)
        backend.set("updown__down", 1)
        backend.step(2)
        assert backend.get("updown__count") == 0xFFFFFE


def test_run_until_counts_the_cycles_to_the_pulse(pair_or_simple):
    for backend in pair_or_simple:
        backend.set("phase__inc", 0x4000)
        # The phase carries at the fourth edge; the pulse is high after it.
        assert backend.run_until("phase__pulse", 100) == 4
        assert backend.run_until("phase__pulse", 100) == 4
        assert backend.run_until("phase__pulse", 3) == 3
        backend.set("phase__inc", 0)
        assert backend.run_until("phase__pulse", 50) == 50
        assert backend.cycle == 61
        # A combinational output is checked on its settled post-edge value too.
        backend.set("updown__load_value", 3)
        backend.set("updown__load", 1)
        backend.step()
        backend.set("updown__load", 0)
        backend.set("updown__down", 1)
        assert backend.run_until("updown__zero", 10) == 3


def test_second_construction_loads_the_cached_model(backends, capfd):
    again = CxxrtlBackend(Zoo())
    assert not again.model.built
    assert again.model.path == backends[1].model.path
    assert capfd.readouterr().err == ""  # no build progress
    again.close()
    with pytest.raises(RuntimeError, match="this CxxrtlBackend is closed"):
        again.step()


def _busy_then_idle(backend: Backend, seed: int) -> None:
    rng = random.Random(seed)
    for _ in range(30):
        for name, port in backend.ports.items():
            if port.is_input:
                backend.set(name, rng.getrandbits(port.width))
        backend.step(rng.randrange(1, 4))
    for name, port in backend.ports.items():
        if port.is_input:
            backend.set(name, 0)


def test_idle_skip_equals_stepping_bit_for_bit(backends):
    stepped, skipping = CxxrtlBackend(Zoo()), backends[1]
    skipping.reset()
    for backend in (stepped, skipping):
        _busy_then_idle(backend, seed=5)
    stepped.step(200_000)
    skipping.step(200_000, skip_idle=True)
    assert skipping.skipped_cycles > 199_000
    assert stepped.skipped_cycles == 0
    names = stepped.probe_names()
    assert (skipping.cycle, probes(skipping, names)) == (stepped.cycle, probes(stepped, names))

    # A free-running divider is never a fixed point: the skip must not fire.
    for backend in (stepped, skipping):
        backend.set("phase__inc", 3)
    skipped = skipping.skipped_cycles
    stepped.step(50_000)
    skipping.step(50_000, skip_idle=True)
    assert skipping.skipped_cycles == skipped
    assert probes(skipping, names) == probes(stepped, names)

    # Waiting for a pulse that cannot come ends at the limit at once.
    for backend in (stepped, skipping):
        backend.set("phase__inc", 0)
    assert skipping.run_until("phase__pulse", 10**6, skip_idle=True) == 10**6
    assert stepped.run_until("phase__pulse", 10**6) == 10**6
    assert skipping.skipped_cycles > skipped + 999_000
    assert (skipping.cycle, probes(skipping, names)) == (stepped.cycle, probes(stepped, names))
    stepped.close()


def _vcd_changes(path: Path) -> dict[str, list[tuple[int, int | str]]]:
    """Each traced signal's value changes, by dotted scope path."""
    header, body = path.read_text().split("$enddefinitions $end")
    scope: list[str] = []
    names: dict[str, list[str]] = {}
    for token in re.finditer(r"\$scope module (\S+) \$end|(\$upscope) \$end"
                             r"|\$var (\S+) \d+ (\S+) (\S+)(?: \[[^\]]*\])? \$end", header):
        if token.group(1):
            scope.append(token.group(1))
        elif token.group(2):
            scope.pop()
        else:
            names.setdefault(token.group(4), []).append(
                ".".join((*scope, token.group(5).lstrip("\\"))))
    changes: dict[str, list[tuple[int, int | str]]] = {
        name: [] for aliases in names.values() for name in aliases}
    time = 0
    for line in body.splitlines():
        if line.startswith("#"):
            time = int(line[1:])
        elif line and not line.startswith("$"):
            value, ident = line[1:].split() if line[0] in "bs" else (line[0], line[1:])
            for name in names.get(ident, ()):
                changes[name].append((time, value if line[0] == "s" else int(value, 2)))
    return changes


def _value_at(changes: list[tuple[int, int | str]], time: int) -> int | str | None:
    """The value after the last change at or before ``time``."""
    values = [value for t, value in changes if t <= time]
    return values[-1] if values else None


def test_vcd_window_has_amaranths_names_and_values(pair, tmp_path):
    pysim, cxxrtl = pair
    paths = {backend: tmp_path / f"{type(backend).__name__}.vcd" for backend in pair}
    rng = random.Random(7)
    for backend, path in paths.items():
        backend.trace(str(path), start_cycle=3, stop_cycle=40)
    while pysim.cycle < 50:
        for name, port in pysim.ports.items():
            if port.is_input and rng.random() < 0.3:
                value = rng.getrandbits(port.width)
                pysim.set(name, value)
                cxxrtl.set(name, value)
        cycles = rng.randrange(1, 5)
        pysim.step(cycles)
        cxxrtl.step(cycles)
    reference, compiled = _vcd_changes(paths[pysim]), _vcd_changes(paths[cxxrtl])
    assert set(stable_names(compiled)) == set(stable_names(reference))
    assert renamed(compiled) == renamed(reference)
    assert "bench.top.bank.regs.value_shadow" in compiled
    times = sorted({t for changes in compiled.values() for t, _ in changes})
    quarter = 250_000_000  # fs
    # Only the window: from its start (inputs stamped between edges) to its last rising edge.
    assert (times[0], times[-1]) == ((4 * 3 - 1) * quarter, (4 * 39 + 2) * quarter)
    # Amaranth writes FSM states and enums as text ("Idle/0"), CXXRTL as numbers.
    text = {name for name, changes in reference.items() if isinstance(changes[0][1], str)}
    assert text == {"bench.top.seq.fsm_state"}
    mismatches = [(name, t) for name in stable_names(list(compiled.keys() - text))
                  for t in times
                  if _value_at(compiled[name], t) != _value_at(reference[name], t)]
    assert mismatches == []


def test_auto_backend_falls_back_to_amaranth_without_a_compiler(monkeypatch, capfd):
    monkeypatch.setenv("CXX", "k37-no-such-compiler")
    backend = make_backend(Zoo())
    assert isinstance(backend, PysimBackend)
    message = capfd.readouterr().err
    assert message.count("\n") == 1
    assert "no C++ compiler" in message
    with pytest.raises(ValueError, match="backend kind must be one of auto, pysim, cxxrtl"):
        make_backend(Zoo(), "verilator")


def test_each_backend_reports_the_name_the_factory_makes_it_by():
    from k37.sim.backends.engine.backend import EngineBackend
    from k37.sim.backends.engine.lockstep import LockstepBackend

    assert (PysimBackend.name, CxxrtlBackend.name, EngineBackend.name,
            LockstepBackend.name) == BACKENDS


@pytest.mark.usefixtures("backends")  # the model is built
def test_auto_backend_is_the_compiled_one_with_a_compiler():
    backend = make_backend(Zoo())
    assert isinstance(backend, CxxrtlBackend)
    backend.close()


def test_bad_names_and_counts_are_refused(pair):
    for backend in pair:
        with pytest.raises(KeyError, match="Zoo has no port 'bus__addr'"):
            backend.set("bus__addr", 1)
        with pytest.raises(ValueError, match="port negc__pos is an output"):
            backend.set("negc__pos", 1)
        with pytest.raises(KeyError, match=r"no signal 'regs\.value_shadow'.*bank\.regs\."):
            backend.probe("regs.value_shadow")
        with pytest.raises(ValueError, match="n must be a non-negative integer, not -1"):
            backend.step(-1)
        with pytest.raises(ValueError, match="stop_cycle must be an integer after start_cycle"):
            backend.trace("unused.vcd", 5, 5)


def test_get_many_reads_what_get_reads(pair):
    names = tuple(sorted(pair[0].ports))  # with the ports wider than 64 bits
    for backend in pair:
        _busy_then_idle(backend, seed=11)
        assert backend.get_many(names) == [backend.get(name) for name in names]
        assert backend.get_many(names[:3]) == [backend.get(name) for name in names[:3]]


def test_recorded_samples_are_the_ports_at_every_multiple_of_the_period(pair):
    pysim, cxxrtl = pair
    names = tuple(n for n, p in sorted(pysim.ports.items()) if not p.is_input and p.width < 64)
    assert not pysim.record(names, 7)
    assert cxxrtl.record(names, 7)
    rng = random.Random(3)
    expected = []
    for k in range(41):
        for name, port in pysim.ports.items():
            if port.is_input and port.width < 64 and (k == 40 or rng.random() < 0.3):
                value = rng.getrandbits(port.width) if k < 40 else 0  # then idle: skipped
                for backend in pair:
                    backend.set(name, value)
        cycles = rng.choice((1, 3, 20, 500)) if k < 40 else 3000
        for _ in range(cycles):
            pysim.step()
            if pysim.cycle % 7 == 0:
                expected.append([pysim.cycle, *pysim.get_many(names)])
        cxxrtl.step(cycles, skip_idle=k == 40 or rng.random() < 0.5)
    assert cxxrtl.recorded().tolist() == expected
    assert cxxrtl.skipped_cycles > 0
    assert cxxrtl.recorded().shape == (0, 1 + len(names)), "each sample is taken once"
    cxxrtl.step(14)
    assert cxxrtl.recorded()[:, 0].tolist() == [pysim.cycle + 7 - pysim.cycle % 7 + k * 7
                                                for k in range(2)]


class Undeclared(Zoo):
    """A Zoo that declares a free-running register the design does not have."""

    free_running = FreeRunning(
        accumulators=(observation.PhaseAccumulator("phase.nowhere", 16),), quiet="phase__pulse")


def test_a_free_running_register_missing_from_the_model_is_refused():
    with pytest.raises(ValueError, match=r"free-running registers phase\.nowhere\.phase, "
                                         r"phase\.nowhere\.stb are not in the compiled model"):
        CxxrtlBackend(Undeclared(("phase",)))


def test_a_design_without_clock_is_refused_before_building():
    with pytest.raises(ValueError, match="Combinational has no sync clock domain"):
        CxxrtlBackend(Combinational())


#: Result and operand widths for the word arithmetic's check: either side of a chunk and of a
#: machine word, and past 128 bits (CXXRTL's own ops).
