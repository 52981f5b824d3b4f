// Stepping a model (model.h): its clock cycles, waveform, recorder, waits and bus cycles, and
// reading and writing its values.
//
// Clocking follows Amaranth's simulator with `add_clock`: the clock starts low, the first cycle
// is a rising edge only, every later cycle is a falling edge then a rising edge (logic in a
// local negedge domain clocked from `clk` runs on the falling edge). `rst` stays low. After a
// cycle the design is settled on its post-edge values, as after `await ctx.tick()`.

#include <algorithm>

#include "model.h"

namespace {

// Compute a settled part's value if CXXRTL outlined it (once per settle: an outline computes
// all its values).
void eval_outline(Model &m, const Part &p) {
	if (p.outline && p.outline != m.outline_fresh && !m.skip_values) {
		p.outline->eval();
		m.outline_fresh = p.outline;
	}
}

void flush_trace(Trace &t) {
	fwrite(t.writer.buffer.data(), 1, t.writer.buffer.size(), t.file);
	t.writer.buffer.clear();
}

// Waveform timestamps, in quarter clock periods, match Amaranth's `add_clock(period)`: the
// rising edge of cycle k at 4k + 2, the falling edge before it at 4k; inputs written after c
// cycles are stamped between a rising edge and the next falling edge, as PysimBackend does.
uint64_t rise_time(uint64_t k) { return 4 * k + 2; }
uint64_t fall_time(uint64_t k) { return 4 * k; }
uint64_t input_time(uint64_t c) { return c == 0 ? 1 : 4 * c - 1; }

void sample(Trace &t, uint64_t quarters) {
	t.started = true;
	t.writer.sample(quarters * t.quarter_period);
	if (t.writer.buffer.size() > (1u << 20))
		flush_trace(t);
}

bool tracing(const Model &m) {
	return m.trace && m.cycle >= m.trace->start && m.cycle < m.trace->stop;
}

// One clock cycle; returns the commits' flags. `Traced` samples the VCD per edge.
template<bool Traced>
inline unsigned cycle(Model &m) {
	unsigned changed = 0;
	if (Traced && !m.trace->started) {
		settle(m);
		sample(*m.trace, input_time(m.cycle));
	}
	if (*m.clk) {
		*m.clk = 0;
		// Without falling-edge logic, only the edge detector needs to see the low level; the
		// rising edge evaluates everything from the committed state anyway.
		changed = m.falling_edge || Traced ? edge<false>(m) : k37_commit_fall(m.top.get());
		if (Traced) {
			mark_stale(m);
			settle(m);
			sample(*m.trace, fall_time(m.cycle));
		}
	}
	*m.clk = 1;
	changed |= edge<true>(m);
	mark_stale(m);
	if (Traced) {
		settle(m);
		sample(*m.trace, rise_time(m.cycle));
	}
	count_cycles(m, 1);
	return changed;
}

// Settle input writes before the clock moves (a combinational wire that needs several delta
// cycles must not race the edge), and stamp them in an active trace.
void prepare(Model &m) {
	if (!m.inputs_written)
		return;
	settle(m);
	m.inputs_written = false;
	if (tracing(m))
		sample(*m.trace, input_time(m.cycle));
}

// Whether an item's committed value is up to date without settling (a register's output).
bool is_state(const Item &item) {
	for (const Part &p : item.parts)
		if (p.outline || !p.next || p.next == p.curr)  // a wire has its own next value
			return false;
	using cxxrtl::debug_item;
	return (item.flags & (debug_item::DRIVEN_SYNC | debug_item::DRIVEN_COMB |
	                      debug_item::UNDRIVEN)) == debug_item::DRIVEN_SYNC;
}

// Whether an item reads non-zero: as it is where `settled` (a register, or a value just
// evaluated); an output port after the skip's evaluation (which computes every output);
// anything else after a settle.
bool nonzero(Model &m, const Item &item, bool settled) {
	if (!settled) {
		if (item.flags & cxxrtl::debug_item::OUTPUT)
			refresh_skip_values(m);
		else
			settle(m);
	}
	for (const Part &p : item.parts)
		for (size_t c = 0; c < (p.width + CHUNK_BITS - 1) / CHUNK_BITS; c++)
			if (p.curr[c])
				return true;
	return false;
}

// Take the recorder's sample of this cycle (outputs as the skip's evaluation computes them).
void record(Model &m) {
	Recorder &r = m.recorder;
	if (r.outputs)
		refresh_skip_values(m);
	else
		settle(m);
	r.rows.push_back(m.cycle);
	for (size_t index : r.items)
		r.rows.push_back(read_u64(m, index));
	r.next += r.every;
}

// Count n cycles run or skipped (a skip ends at the next sample at the latest), and take the
// recorder's sample if one is due.
void count_cycles(Model &m, uint64_t n) {
	m.cycle += n;
	if (m.cycle == m.recorder.next)
		record(m);
}

// Set a register (both its committed and its next value) to `value`. The parts that read it
// or compute it run at the next edge only if it changed (a commit leaves next = curr).
void write_state(Model &m, size_t index, uint64_t value) {
	const Part &p = m.items[index].parts.front();
	if (word(p, p.curr) == value && word(p, p.next) == value)
		return;
	*m.dirty |= p.touches;
	for (chunk_t *v : {p.curr, p.next}) {
		v[0] = chunk_t(value);
		if (p.width > 32)
			v[1] = chunk_t(value >> 32);
	}
}

int64_t sign_extend(uint64_t raw, size_t width) {
	if (width < 64 && (raw >> (width - 1) & 1))
		raw |= ~uint64_t(0) << width;
	return int64_t(raw);
}

// Run n untraced cycles; with skip_idle, skip ahead after each cycle that changed only the
// free-running state.
void run_fast(Model &m, uint64_t n, bool skip_idle) {
	for (uint64_t i = 0; i < n;) {
		unsigned flags = cycle<false>(m);
		i++;
		if (skip_idle)
			i += try_skip(m, flags, n - i);
	}
}

void close_trace(Model &m) {
	if (m.trace) {
		flush_trace(*m.trace);
		fclose(m.trace->file);
		m.trace.reset();
	}
}

// Cycles before the trace window's next boundary (or n if no window lies ahead).
uint64_t until_boundary(const Model &m, uint64_t n) {
	if (!m.trace || m.cycle >= m.trace->stop)
		return n;
	uint64_t boundary = m.cycle < m.trace->start ? m.trace->start : m.trace->stop;
	return std::min(n, boundary - m.cycle);
}

void advance(Model &m, uint64_t n, bool skip_idle) {
	while (n) {
		uint64_t k = until_boundary(m, n);
		if (tracing(m))
			for (uint64_t i = 0; i < k; i++)
				cycle<true>(m);
		else
			run_fast(m, k, skip_idle);
		n -= k;
		if (m.trace && m.cycle >= m.trace->stop)
			close_trace(m);
	}
}

// run_until for a combinational port (settled only by an evaluation), untraced, from a high
// clock: rather than settle after each rising edge and then evaluate the falling edge, read
// the port after the falling edge's evaluation, which computes the output ports from the
// state that the rising edge left (k37_can_peek, k37_eval_fall). If it is set, the falling edge
// is undone (its next values discarded, the clock high again) and the wait ends one cycle back.
uint64_t run_until_peek(Model &m, const Item &item, uint64_t limit, bool skip_idle) {
	for (uint64_t i = 0; i < limit;) {
		*m.clk = 0;
		// The falling edge's next values, and the port from the state that the rising edge
		// left (the falling edge's commit comes after the peek).
		if (item.parts.size() == 1 && k37_eval_port(m.top.get(), item.parts[0].curr))
			k37_eval_fall(m.top.get());
		else
			k37_eval_peek(m.top.get());
		if (i > 0 && nonzero(m, item, true)) {
			*m.clk = 1;
			k37_discard_fall(m.top.get());
			mark_stale(m);
			return i;
		}
		unsigned flags = k37_commit_fall(m.top.get());
		*m.clk = 1;
		flags |= edge<true>(m);
		mark_stale(m);
		count_cycles(m, 1);
		i++;
		if (skip_idle)
			i += try_skip(m, flags, limit - i, &item);
	}
	mark_stale(m);
	return limit;
}

// Run n cycles (k37_step) on a model.
void step(Model &m, uint64_t n, bool skip_idle) {
	prepare(m);
	advance(m, n, skip_idle);
}

// k37_run_until on a model.
uint64_t run_until(Model &m, const Item &item, uint64_t limit, bool skip_idle) {
	prepare(m);
	const bool state = is_state(item);
	if (m.can_peek && !state && *m.clk && !m.trace)
		return run_until_peek(m, item, limit, skip_idle);
	for (uint64_t i = 0; i < limit;) {
		if (tracing(m)) {
			cycle<true>(m);
			i++;
			if (m.cycle >= m.trace->stop)
				close_trace(m);
		} else {
			unsigned flags = cycle<false>(m);
			i++;
			// A skip is taken only if the item reads zero: at a fixed point it stays so.
			if (skip_idle)
				i += try_skip(m, flags, until_boundary(m, limit - i), &item, state);
		}
		if (nonzero(m, item, state))
			return i;
	}
	return limit;
}

// Write a port's next value (as k37_set).
void set_port(Model &m, size_t index, uint64_t value) {
	const Part &p = m.items[index].parts.front();
	if (p.width < 64)
		value &= (uint64_t(1) << p.width) - 1;  // CXXRTL values keep their unused bits zero
	p.next[0] = chunk_t(value);
	if (p.width > 32)
		p.next[1] = chunk_t(value >> 32);
	*m.dirty |= p.touches;
	m.inputs_written = true;
	mark_stale(m);
}

// A host bus read cycle (k37_bus_read) on a model.
uint64_t bus_read(Model &m, const size_t *bus, uint64_t address) {
	set_port(m, bus[0], address);
	set_port(m, bus[1], 1);
	step(m, 1, false);
	set_port(m, bus[1], 0);
	settle(m);
	return read_u64(m, bus[2]);
}

}  // namespace

