// A C ABI over one CXXRTL model, for ctypes (see sim/backends/cxxrtl/backend.py).
//
// This file does not depend on the design, so it is compiled once per toolchain and linked
// with each design's object, which defines k37_make_top() (the output of `write_cxxrtl` for
// top module "top" plus a factory). Every named signal is reached through CXXRTL's debug items:
// ports and probes are items, found by index.
//
// Clocking follows Amaranth's simulator with `add_clock`: the clock starts low, the first cycle
// is a rising edge only, every later cycle is a falling edge then a rising edge (logic in a
// local negedge domain clocked from `clk` runs on the falling edge). `rst` stays low. After a
// cycle the design is settled on its post-edge values, as after `await ctx.tick()`.

#include <cxxrtl/cxxrtl.h>
#include <cxxrtl/cxxrtl_vcd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

cxxrtl::module *k37_make_top();
// Whether anything but rising edges of `clk` matters (falling-edge logic, derived clocks).
bool k37_needs_falling_edge();
// Commits after a falling or a rising edge of `clk`: of the wires that edge can change (and
// those written outside any edge), or all wires (codegen.py, edge_wires). They return CHANGED if
// any wire changed, | REST_CHANGED if any but the free-running state's did.
unsigned k37_commit_fall(cxxrtl::module *top);
unsigned k37_commit_rise(cxxrtl::module *top);
// Whether the eval() of a falling edge computes every combinational value as a settle would;
// then k37_discard_fall() forgets the next values that eval() wrote, undoing the edge.
bool k37_can_peek();
// eval() at a falling edge of `clk`: computes the negedge registers' next values, possibly
// nothing else (codegen.py, fall_eval), and nothing at all if none of their inputs changed since
// it last ran (codegen.py, design_main); other combinational values are stale.
bool k37_eval_fall(cxxrtl::module *top);
void k37_discard_fall(cxxrtl::module *top);
// eval() at a falling edge of `clk` that computes the output ports too, whatever changed: for
// a peek (k37_can_peek); k37_eval_fall() may compute nothing where no input of the negedge
// registers changed.
bool k37_eval_peek(cxxrtl::module *top);
// Compute the output port whose value is at `curr` from the state, and nothing else (codegen.py,
// port_eval); false (computing nothing) for any other value.
bool k37_eval_port(cxxrtl::module *top, const cxxrtl::chunk_t *curr);
// eval() at a rising edge of `clk`: computes the posedge registers' next values, possibly
// nothing else (codegen.py, rise_eval); the combinational values are stale after it.
bool k37_eval_rise(cxxrtl::module *top);
// The parts of the design that the next k37_eval_rise() runs (codegen.py, rise_eval): those
// whose support changed; the commits add the readers of each wire that changed, and what writes
// state or an input adds k37_touches() of the value it writes (by its current value's chunks):
// the parts that read it or own it (all for an unknown value).
uint64_t *k37_dirty(cxxrtl::module *top);
uint64_t k37_touches(cxxrtl::module *top, const cxxrtl::chunk_t *curr);
// Whether k37_eval_skip() computes what a skip decision reads (codegen.py, skip_eval): the
// values of the free-running state's declared signals, `quiet` and the output ports, from the
// state, and nothing else (other combinational values are stale).
bool k37_has_eval_skip();
void k37_eval_skip(cxxrtl::module *top);

extern "C" {

// The rate multiplier's decoding (hdl/rate_multiplier.py), as its reference model defines it
// (hdl/rate_multiplier_model.py; tests/test_rate_multiplier.py pins these to it): counter state
// `state` of a `width`-bit cascade passes the input clock for word bit width - 1 - t, t its
// trailing ones, and for none (width) when it is all ones. The states with t trailing ones are
// those equal to 2^t - 1 modulo 2^(t + 1).
unsigned k37_rm_selected_bit(uint64_t state, unsigned width) {
	unsigned ones = 0;
	while (ones < width && (state >> ones & 1))
		ones++;
	return ones < width ? width - 1 - ones : width;
}

// Input clocks that pass without a pulse from counter state `count` on (clock i, from 0,
// reaches state count + 1 + i): the fewest before a state that selects a set bit of `word`,
// UINT64_MAX if `word` is 0.
uint64_t k37_rm_clocks_before_pulse(uint64_t count, uint64_t word, unsigned width) {
	uint64_t first = count + 1, clocks = UINT64_MAX;
	uint64_t bits = width < 64 ? word & ((uint64_t(1) << width) - 1) : word;
	for (; bits; bits &= bits - 1) {
		unsigned t = width - 1 - unsigned(__builtin_ctzll(bits));  // word bit width - 1 - t
		clocks = std::min(clocks, ((uint64_t(1) << t) - 1 - first) & ((uint64_t(2) << t) - 1));
	}
	return clocks;
}

}  // extern "C"

namespace {

constexpr unsigned CHANGED = 1, REST_CHANGED = 2;

using cxxrtl::chunk_t;
constexpr size_t CHUNK_BITS = 8 * sizeof(chunk_t);

struct Part {
	chunk_t *curr;
	chunk_t *next;
	size_t width;
	size_t lsb;
	cxxrtl::debug_outline *outline;
	uint64_t touches;  // k37_touches()
};

struct Item {
	std::string name;
	std::vector<Part> parts;
	size_t width;
	uint32_t flags;
};

struct Trace {
	cxxrtl::debug_items items;
	cxxrtl::vcd_writer writer;
	FILE *file;
	uint64_t start, stop, quarter_period;
	bool started;  // the first sample (every value) is written
};

// A phase accumulator that runs on by itself (hdl/divider.py): phase += increment at every
// rising edge, stb holds the carry out of the last addition.
struct Accumulator {
	size_t phase, increment, stb;  // item indices
	unsigned width;
};

// A counter (the rate multiplier's, hdl/rate_multiplier.py) that counts the cycles in which
// accumulator `clock`'s stb is high; `select` is the word bit that state count + 1 selects
// (k37_rm_selected_bit).
struct StrobeCounter {
	size_t count, select;
	unsigned width;
	size_t clock;
	// Its output: a pulse in a strobe cycle iff the word bit selected is set. While `gate`
	// reads non-zero, the pulses matter and skips stop before the next one.
	size_t word, gate;
};

// An accel/decel accumulator (hdl/accel_decel.py): at each strobe of accumulator `clock`,
// y += x, and a carry out of its n bits moves a count from x to its output. Skips stop before
// its next carry; x (and everything the carry feeds) is ordinary state.
struct CarryAccumulator {
	size_t y, x;
	unsigned n;
	bool x_signed;
	size_t clock;
};

// A register that goes down by one each cycle while it is not 0 (the K3701's step latency
// count); skips stop before it reaches `stop`.
struct Countdown {
	size_t count;
	uint64_t stop;
};

// A servo plant (sim/machine/plant.py), stepped natively while it moves within one encoder count:
// v += round((vc - v) alpha / 2^alpha_bits), or v = vc if that rounds to 0 (0 if stalled);
// before += v; the count is (before + v) >> frac_bits. A skip ends with the cycle that changes
// a count.
struct Plant {
	size_t velocity, before, dac, dac_zero, gain, alpha, vmax, stall;  // item indices
	unsigned vc_bits, alpha_bits, frac_bits;
};

// Samples of some items (of at most 64 bits) at every multiple of `every` cycles, taken as
// the clock reaches it (k37_record): settled, or outputs as the skip evaluation computes them.
struct Recorder {
	std::vector<size_t> items;
	bool outputs = false;  // every item is an output port or a register
	uint64_t every = 0, next = UINT64_MAX;
	std::vector<uint64_t> rows;  // per sample: the cycle, then each item's value
};

struct PlantState;

struct Model {
	std::unique_ptr<cxxrtl::module> top{k37_make_top()};
	const bool falling_edge = k37_needs_falling_edge();
	const bool can_peek = k37_can_peek();
	const bool has_eval_skip = k37_has_eval_skip();
	uint64_t *const dirty = k37_dirty(top.get());
	std::vector<Item> items;
	chunk_t *clk = nullptr;
	uint64_t cycle = 0;
	uint64_t skipped = 0;
	bool inputs_written = true;  // since the last cycle
	bool stale = true;           // combinational values may lag the state
	// The outline (CXXRTL's combinational values that only debug_eval computes) evaluated
	// since the last settle, if any.
	cxxrtl::debug_outline *outline_fresh = nullptr;
	// The skip's signals computed by k37_eval_skip since the state last changed (outlined
	// ones included; nothing else may be read).
	bool skip_values = false;
	std::unique_ptr<Trace> trace;
	// Idle skipping with free-running state (see try_skip).
	std::vector<Accumulator> accumulators;
	std::vector<StrobeCounter> counters;
	std::vector<CarryAccumulator> carries;
	std::vector<Plant> plants;
	std::vector<Countdown> countdowns;
	size_t quiet = SIZE_MAX;  // item: the free-running state affects nothing else
	Recorder recorder;
	// Scratch space of a skip (kept to spare an allocation per skip).
	std::vector<PlantState> plant_states;
	std::vector<int64_t> plant_steps;
	std::vector<uint64_t> strobes;
};

// The state (or an input) changed: every combinational value may lag it, the skip's too.
inline void mark_stale(Model &m) {
	m.stale = true;
	m.skip_values = false;
}

// One clock edge, as CXXRTL's module::step(): evaluate and commit until converged; returns
// the commits' flags (CHANGED, REST_CHANGED). Combinational values computed from committed state are not
// recomputed, so they may lag until the next evaluation. `Rising` tells which edge this is,
// so that only the wires it can change are committed.
template<bool Rising>
inline unsigned edge(Model &m) {
	unsigned changed = 0;
	for (;;) {
		bool converged = Rising ? k37_eval_rise(m.top.get()) : k37_eval_fall(m.top.get());
		unsigned committed = Rising ? k37_commit_rise(m.top.get()) : k37_commit_fall(m.top.get());
		changed |= committed;
		if (!committed || converged)
			return changed;
	}
}

// Evaluate until the values converge, so that every combinational value follows the state
// (as CXXRTL's module::step(): a converged evaluation needs no second one after its commit).
inline void settle(Model &m) {
	if (m.stale) {
		bool converged;
		do
			converged = m.top->eval();
		while (m.top->commit() && !converged);
		m.stale = false;
		m.outline_fresh = nullptr;
		m.skip_values = false;
	}
}

// Bring what a skip decision reads up to date with the state: k37_eval_skip computes just
// that, where the model has it; else a settle.
inline void refresh_skip_values(Model &m) {
	if (!m.has_eval_skip) {
		settle(m);
	} else if (m.stale && !m.skip_values) {
		k37_eval_skip(m.top.get());
		m.skip_values = true;
	}
}

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

void count_cycles(Model &m, uint64_t n);

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

// The value at `v` (a part's current or next chunks) of a part of at most 64 bits.
inline uint64_t word(const Part &p, const chunk_t *v) {
	return p.width > 32 ? uint64_t(v[1]) << 32 | v[0] : v[0];
}

inline __attribute__((always_inline)) uint64_t read_u64(Model &m, size_t index) {
	const Part &p = m.items[index].parts.front();
	eval_outline(m, p);
	return word(p, p.curr);
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

using u128 = unsigned __int128;
using i128 = __int128;

// a / b truncated, as C++ divides (b != 0): in 64 bits where both fit (the common case; a
// 128-bit division is a library call).
inline i128 quotient(i128 a, i128 b) {
	if (a == int64_t(a) && b == int64_t(b) && !(int64_t(a) == INT64_MIN && b == -1))
		return int64_t(a) / int64_t(b);
	return a / b;
}

// a / b rounded up (b > 0).
i128 ceil_div(i128 a, i128 b) {
	i128 q = quotient(a, b);
	return q + (a - q * b > 0 ? 1 : 0);
}

int64_t sign_extend(uint64_t raw, size_t width) {
	if (width < 64 && (raw >> (width - 1) & 1))
		raw |= ~uint64_t(0) << width;
	return int64_t(raw);
}

// x of a carry accumulator, sign-extended if signed.
int64_t read_x(Model &m, const CarryAccumulator &c) {
	uint64_t raw = read_u64(m, c.x);
	return c.x_signed ? sign_extend(raw, m.items[c.x].width) : int64_t(raw);
}

// The most cycles that can run while accumulator `acc`'s strobe is seen at most `safe` times
// (UINT64_MAX: no limit).
uint64_t cycles_within(Model &m, const Accumulator &acc, uint64_t safe) {
	uint64_t s0 = read_u64(m, acc.stb), inc = read_u64(m, acc.increment);
	if (s0 > safe)
		return 0;
	if (inc == 0)
		return UINT64_MAX;
	// Strobes seen in k cycles: s0 + floor((phase + (k - 1) inc) / 2^w) <= safe.
	u128 limit = (u128(safe - s0 + 1) << acc.width) - read_u64(m, acc.phase);
	u128 top = limit + inc - 1;
	u128 cycles = top >> 64 ? top / inc : uint64_t(top) / uint64_t(inc);
	return cycles < UINT64_MAX ? uint64_t(cycles) : UINT64_MAX;
}

// The most cycles that can run before the next event of the free-running state: a carry
// accumulator's carry, a strobe counter's output pulse while its gate is open, or a countdown
// reaching its stop (UINT64_MAX: none comes), from the current (settled) state.
uint64_t event_horizon(Model &m) {
	uint64_t horizon = UINT64_MAX;
	for (const Countdown &c : m.countdowns) {
		uint64_t count = read_u64(m, c.count);
		if (count != 0)
			horizon = std::min(horizon, count > c.stop ? count - c.stop : 0);
	}
	for (const CarryAccumulator &c : m.carries) {
		int64_t x = read_x(m, c);
		if (x == 0)
			continue;
		uint64_t y = read_u64(m, c.y), full = uint64_t(1) << c.n;
		// Strobes that may come without a carry: y + s x stays in [0, 2^n).
		uint64_t safe = x > 0 ? (full - 1 - y) / uint64_t(x) : y / uint64_t(-x);
		horizon = std::min(horizon, cycles_within(m, m.accumulators[c.clock], safe));
	}
	for (const StrobeCounter &c : m.counters) {
		if (c.gate == SIZE_MAX || !read_u64(m, c.gate))
			continue;
		// The strobes before the first that gives a pulse.
		uint64_t strobes = k37_rm_clocks_before_pulse(read_u64(m, c.count), read_u64(m, c.word),
		                                              c.width);
		if (strobes != UINT64_MAX)
			horizon = std::min(horizon, cycles_within(m, m.accumulators[c.clock], strobes));
	}
	return horizon;
}

// One plant's registers and (constant) inputs, and its update, as sim/machine/plant.py computes
// them:
// the position (before + v, what the count is taken from) and the velocity.
struct PlantState {
	int64_t v, vc, alpha;
	uint64_t position, low;  // low: the first position of the current count
	bool stall;
	unsigned vc_bits, alpha_bits, frac_bits;

	PlantState(Model &m, const Plant &p)
	    : v(sign_extend(read_u64(m, p.velocity), p.vc_bits + 1)),
	      alpha(int64_t(read_u64(m, p.alpha))), stall(read_u64(m, p.stall) != 0),
	      vc_bits(p.vc_bits), alpha_bits(p.alpha_bits), frac_bits(p.frac_bits) {
		int64_t err = int64_t(read_u64(m, p.dac)) - int64_t(read_u64(m, p.dac_zero));
		int64_t raw = err * int64_t(read_u64(m, p.gain));
		int64_t top = (int64_t(1) << vc_bits) - 1;
		uint64_t limit = read_u64(m, p.vmax);
		int64_t vmax = limit == 0 || limit > uint64_t(top) ? top : int64_t(limit);
		vc = raw > vmax ? vmax : raw < -vmax ? -vmax : raw;
		position = read_u64(m, p.before) + uint64_t(v);
		low = position >> frac_bits << frac_bits;
	}
	// The velocity after the next update (in range: |vc|, |v| <= 2^vc_bits - 1).
	int64_t next_v() const {
		uint64_t delta = uint64_t(vc - v) * uint64_t(alpha) + (uint64_t(1) << (alpha_bits - 1));
		int64_t step = int64_t(delta) >> alpha_bits;
		return stall ? 0 : step == 0 ? vc : v + step;
	}
	// Whether a velocity of `next` keeps the count.
	bool keeps_count(int64_t next) const {
		return (position + uint64_t(next) - low) >> frac_bits == 0;
	}
	void take(int64_t next) {
		v = next;
		position += uint64_t(next);
	}
	// Whether the velocity stays as it is (then the position moves by v every cycle).
	bool steady() const {
		return v == (stall ? 0 : vc);
	}
	// At a steady velocity: how many cycles keep the count.
	uint64_t steady_cycles() const {
		uint64_t offset = position - low;
		if (v == 0)
			return UINT64_MAX;
		return v > 0 ? ((uint64_t(1) << frac_bits) - 1 - offset) / uint64_t(v)
		             : offset / uint64_t(-v);
	}
	// The velocity step of the next update, if it is a ramp step (v moves by it), else 0
	// (the update lands the velocity: stalled, or the step rounds to 0 and v = vc).
	int64_t ramp_step() const {
		if (stall)
			return 0;
		uint64_t delta = uint64_t(vc - v) * uint64_t(alpha) + (uint64_t(1) << (alpha_bits - 1));
		return int64_t(delta) >> alpha_bits;
	}
	// For a ramp step s != 0: the updates (>= 1) that all step by s, as vc - v moves by s per
	// update through the range of differences that round to s.
	uint64_t ramp_cycles(int64_t s) const {
		i128 e = i128(vc) - v, scale = i128(1) << alpha_bits, half = scale >> 1;
		if (s > 0) {  // e * alpha + half >= s * 2^bits: e >= e_min
			i128 e_min = ceil_div(i128(s) * scale - half, alpha);
			return uint64_t(quotient(e - e_min, s)) + 1;
		}
		// e * alpha + half < (s + 1) * 2^bits: e <= e_max
		i128 e_max = ceil_div((i128(s) + 1) * scale - half, alpha) - 1;
		return uint64_t(quotient(e_max - e, -i128(s))) + 1;
	}
	// The position's offset in its count after j ramp steps of s.
	i128 offset_after(int64_t s, uint64_t j) const {
		return i128(position - low) + i128(j) * v + i128(s) * i128(j) * i128(j + 1) / 2;
	}
	bool offset_keeps(i128 offset) const {
		return offset >= 0 && offset < (i128(1) << frac_bits);
	}
	// On a monotonic stretch of steps where step `good` keeps the count and step `bad` does
	// not, move both towards the last step that keeps it, from where the offset's quadratic
	// crosses the bound it leaves by (rounded, then checked exactly: only a bracket of
	// checked steps is kept).
	void narrow(int64_t s, uint64_t &good, uint64_t &bad) const {
		bool above = offset_after(s, bad) >= (i128(1) << frac_bits);
		double bound = above ? double(int64_t(1) << frac_bits) : 0.0;
		// s/2 j^2 + (v + s/2) j + (offset now - bound) = 0
		double a = 0.5 * double(s), b = double(v) + 0.5 * double(s);
		double c = double(position - low) - bound;
		double disc = b * b - 4 * a * c;
		if (disc < 0)
			return;
		for (double root : {(-b + std::sqrt(disc)) / (2 * a), (-b - std::sqrt(disc)) / (2 * a)}) {
			if (!(root > double(good) && root < double(bad) + 1))
				continue;
			uint64_t j = uint64_t(root);  // the real crossing lies after step j
			for (uint64_t k : {j - 1, j, j + 1})
				if (k > good && k < bad)
					(offset_keeps(offset_after(s, k)) ? good : bad) = k;
			return;
		}
	}
	// Of n ramp steps of s, how many keep the count (every one up to that point does): the
	// offset is a quadratic in the steps taken, monotonic on each side of its vertex.
	uint64_t ramp_keeps(int64_t s, uint64_t n) const {
		// vertex of j v + s j (j + 1) / 2: j* = -v / s - 1/2; split [1, n] there
		i128 vertex = quotient(-i128(v), s);
		uint64_t split = vertex < 1 ? 0 : vertex >= i128(n) ? n : uint64_t(vertex);
		uint64_t lo = 1;
		for (uint64_t hi : {split, n}) {
			if (hi < lo)
				continue;
			// on [lo, hi] the offset is monotonic: find the first step that leaves the count
			if (!offset_keeps(offset_after(s, lo)))
				return lo - 1;
			if (!offset_keeps(offset_after(s, hi))) {
				uint64_t good = lo, bad = hi;
				narrow(s, good, bad);
				while (bad - good > 1) {
					uint64_t mid = good + (bad - good) / 2;
					(offset_keeps(offset_after(s, mid)) ? good : bad) = mid;
				}
				return good;
			}
			lo = hi + 1;
		}
		return n;
	}
	void take_ramp(int64_t s, uint64_t j) {
		position = low + uint64_t(offset_after(s, j));
		v += s * int64_t(j);
	}
};

// Step the plants natively for up to `limit` cycles, up to and including the first cycle
// that changes a count (then `crossed`), and return the cycles stepped (their state written).
// That cycle is the skip's last: what reads a plant (its encoder lines, its count) reads the
// position before the cycle's update, still in the old count, and the new count is first
// read by the next cycle, which is evaluated. Exact, and in pieces: while every velocity is
// steady, in closed form; while each ramps (v += s every cycle for a constant rounded step
// s), piece by piece, the position a quadratic in the cycles; a cycle that lands a velocity,
// one at a time. `resume`: the plants' states are those the last call left (a skip going on
// past a sample), not read again from the model.
uint64_t advance_plants(Model &m, uint64_t limit, bool resume, bool &crossed) {
	crossed = false;
	if (m.plants.empty() || limit == 0)
		return limit;
	std::vector<PlantState> &states = m.plant_states;
	if (!resume) {
		states.clear();
		for (const Plant &p : m.plants)
			states.emplace_back(m, p);
	}
	std::vector<int64_t> &steps = m.plant_steps;
	steps.resize(states.size());
	uint64_t k = 0;
	while (k < limit) {
		if (std::all_of(states.begin(), states.end(),
		                [](const PlantState &s) { return s.steady(); })) {
			uint64_t run = limit - k;
			for (const PlantState &s : states)
				run = std::min(run, s.steady_cycles());
			for (PlantState &s : states)
				s.position += uint64_t(s.v) * run;
			k += run;
			break;
		}
		// The longest piece over which each plant's update is the same kind: a ramp step of
		// constant s, or (steady) none; a landing update is a piece of one cycle.
		uint64_t run = limit - k;
		bool landing = false;
		for (size_t i = 0; i < states.size(); i++) {
			const PlantState &s = states[i];
			steps[i] = s.steady() ? 0 : s.ramp_step();
			if (!s.steady() && steps[i] == 0)
				landing = true;
			else if (steps[i] != 0)
				run = std::min(run, s.ramp_cycles(steps[i]));
		}
		if (landing) {
			bool keeps = true;
			for (size_t i = 0; i < states.size(); i++) {
				steps[i] = states[i].next_v();
				keeps &= states[i].keeps_count(steps[i]);
			}
			if (!keeps)
				break;
			for (size_t i = 0; i < states.size(); i++)
				states[i].take(steps[i]);
			k++;
			continue;
		}
		uint64_t keep = run;
		for (size_t i = 0; i < states.size(); i++)
			keep = std::min(keep, steps[i] != 0 ? states[i].ramp_keeps(steps[i], run)
			                                     : std::min(run, states[i].steady_cycles()));
		for (size_t i = 0; i < states.size(); i++) {
			if (steps[i] != 0)
				states[i].take_ramp(steps[i], keep);
			else
				states[i].position += uint64_t(states[i].v) * keep;
		}
		k += keep;
		if (keep < run)
			break;  // the next cycle changes a count
	}
	if (k < limit) {  // stopped before a cycle that changes a count: step it, the last
		for (PlantState &s : states)
			s.take(s.next_v());
		k++;
		crossed = true;
	}
	for (size_t i = 0; i < states.size(); i++) {
		const Plant &p = m.plants[i];
		write_state(m, p.velocity, uint64_t(states[i].v) & ((uint64_t(1) << (p.vc_bits + 1)) - 1));
		write_state(m, p.before, states[i].position - uint64_t(states[i].v));
	}
	return k;
}

// Whether a plant's count changed in the last cycle: its position before that cycle's update
// is its `before` register now (before += v), its position now is before + v.
bool plants_moved(Model &m) {
	for (const Plant &p : m.plants) {
		uint64_t before = read_u64(m, p.before);
		uint64_t v = uint64_t(sign_extend(read_u64(m, p.velocity), p.vc_bits + 1));
		if ((before + v) >> p.frac_bits != before >> p.frac_bits)
			return true;
	}
	return false;
}

// Advance the free-running state by k cycles (k >= 1) in closed form (no carry on the way).
void advance_free(Model &m, uint64_t k) {
	std::vector<uint64_t> &strobes = m.strobes;  // stb highs seen in the k cycles
	strobes.resize(m.accumulators.size());
	for (size_t a = 0; a < m.accumulators.size(); a++) {
		const Accumulator &acc = m.accumulators[a];
		u128 phase = read_u64(m, acc.phase), inc = read_u64(m, acc.increment);
		u128 before_last = phase + u128(k - 1) * inc, total = before_last + inc;
		strobes[a] = read_u64(m, acc.stb) + uint64_t(before_last >> acc.width);
		write_state(m, acc.phase, uint64_t(total & ((u128(1) << acc.width) - 1)));
		write_state(m, acc.stb, uint64_t((total >> acc.width) - (before_last >> acc.width)));
	}
	for (const StrobeCounter &c : m.counters) {
		uint64_t mask = (uint64_t(1) << c.width) - 1;
		uint64_t count = (read_u64(m, c.count) + strobes[c.clock]) & mask;
		write_state(m, c.count, count);
		write_state(m, c.select, k37_rm_selected_bit((count + 1) & mask, c.width));
	}
	for (const CarryAccumulator &c : m.carries) {
		int64_t x = read_x(m, c);
		uint64_t y = read_u64(m, c.y) + uint64_t(int64_t(strobes[c.clock]) * x);
		write_state(m, c.y, y & ((uint64_t(1) << c.n) - 1));
	}
	for (const Countdown &c : m.countdowns) {
		uint64_t count = read_u64(m, c.count);
		if (count != 0)
			write_state(m, c.count, count - k);
	}
}

// After a cycle whose commits returned `flags` (the clock high): if it changed no state but
// the free-running state's, no plant's count, and the quiet item reads 1, the rest of the
// design is at a fixed point until the next event of the free-running state; skip up to `rest`
// cycles, to just before that event, advancing the free-running state exactly. Not if item
// `watch` (when given) reads non-zero. A recorder sample on the way is taken (as after a
// stepped cycle) and the skip goes on from it, the rest still at its fixed point.
// Returns the cycles skipped.
uint64_t try_skip(Model &m, unsigned flags, uint64_t rest, const Item *watch = nullptr,
                  bool watch_state = false) {
	if (flags & REST_CHANGED || rest == 0 || plants_moved(m) ||
	    (watch && nonzero(m, *watch, watch_state)))
		return 0;
	if (flags & CHANGED && m.quiet == SIZE_MAX)
		return 0;
	uint64_t skipped = 0;
	// The cycles to the free-running state's next event: computed once, as the skip's samples
	// change nothing it depends on.
	uint64_t horizon = 0;
	bool crossed = false;  // a plant's count changed in the last cycle skipped
	while (skipped < rest) {
		uint64_t to_sample = m.recorder.next - m.cycle;
		uint64_t run = std::min(rest - skipped, to_sample);
		if (flags & CHANGED) {
			if (skipped == 0) {
				refresh_skip_values(m);
				if (!read_u64(m, m.quiet))
					break;
				horizon = event_horizon(m);
			}
			run = advance_plants(m, std::min(run, horizon), skipped != 0, crossed);
			if (run == 0)
				break;
			advance_free(m, run);
			horizon -= run;
			mark_stale(m);
		}
		m.skipped += run;
		skipped += run;
		count_cycles(m, run);
		if (run < to_sample || crossed)
			break;  // an event comes next (a count read, or the free-running state's), or done
	}
	return skipped;
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

extern "C" {

void *k37_create() {
	Model *m = new Model;
	cxxrtl::debug_items items;
	m->top->debug_info(&items, nullptr, "");
	for (auto &entry : items.table) {
		if (entry.second.front().type == cxxrtl::debug_item::MEMORY)
			continue;
		Item item{entry.first, {}, 0, entry.second.front().flags};
		for (const cxxrtl::debug_item &d : entry.second) {
			item.parts.push_back(Part{d.curr, d.next, d.width, d.lsb_at, d.outline,
			                          k37_touches(m->top.get(), d.curr)});
			item.width = std::max(item.width, d.lsb_at + d.width);
		}
		if (entry.first == "clk")
			m->clk = item.parts.front().curr;
		m->items.push_back(std::move(item));
	}
	return m;
}

void k37_destroy(void *handle) {
	Model *m = static_cast<Model *>(handle);
	close_trace(*m);
	delete m;
}

size_t k37_count(void *handle) {
	return static_cast<Model *>(handle)->items.size();
}

const char *k37_name(void *handle, size_t index) {
	return static_cast<Model *>(handle)->items[index].name.c_str();
}

size_t k37_width(void *handle, size_t index) {
	return static_cast<Model *>(handle)->items[index].width;
}

// Read an item into `out` (ceil(width / 32) little-endian 32-bit words, zeroed by the caller).
void k37_read(void *handle, size_t index, uint32_t *out) {
	Model &m = *static_cast<Model *>(handle);
	settle(m);
	for (const Part &p : m.items[index].parts) {
		eval_outline(m, p);
		for (size_t bit = 0; bit < p.width; bit++)
			if (p.curr[bit / CHUNK_BITS] >> (bit % CHUNK_BITS) & 1) {
				size_t at = p.lsb + bit;
				out[at / 32] |= uint32_t(1) << (at % 32);
			}
	}
}

// Write an item from `data` (same layout as k37_read); for inputs, takes effect at once.
void k37_write(void *handle, size_t index, const uint32_t *data) {
	Model &m = *static_cast<Model *>(handle);
	for (const Part &p : m.items[index].parts) {
		for (size_t c = 0; c < (p.width + CHUNK_BITS - 1) / CHUNK_BITS; c++)
			p.next[c] = 0;
		for (size_t bit = 0; bit < p.width; bit++) {
			size_t at = p.lsb + bit;
			if (data[at / 32] >> (at % 32) & 1)
				p.next[bit / CHUNK_BITS] |= chunk_t(1) << (bit % CHUNK_BITS);
		}
		*m.dirty |= p.touches;
	}
	m.inputs_written = true;
	mark_stale(m);
}

// Fast paths for items of at most 64 bits and one part (every port).
uint64_t k37_get(void *handle, size_t index) {
	Model &m = *static_cast<Model *>(handle);
	settle(m);
	return read_u64(m, index);
}

// k37_get of n items into out[0 .. n).
void k37_get_many(void *handle, const size_t *indices, size_t n, uint64_t *out) {
	for (size_t i = 0; i < n; i++)
		out[i] = k37_get(handle, indices[i]);
}

void k37_set(void *handle, size_t index, uint64_t value) {
	set_port(*static_cast<Model *>(handle), index, value);
}

void k37_step(void *handle, uint64_t n, int skip_idle) {
	step(*static_cast<Model *>(handle), n, skip_idle != 0);
}

// Step until item `index` reads non-zero after a rising edge, or `limit` cycles; returns the
// cycles stepped. With skip_idle, a full cycle without any state change (so the item stays
// zero for ever) ends the wait at the limit at once.
uint64_t k37_run_until(void *handle, size_t index, uint64_t limit, int skip_idle) {
	Model &m = *static_cast<Model *>(handle);
	return run_until(m, m.items[index], limit, skip_idle != 0);
}

// One host bus write cycle (sim/testbench.py bus_write): the byte is taken at the edge.
void k37_bus_write(void *handle, size_t addr, size_t w_data, size_t w_stb, uint64_t address,
                   uint64_t data) {
	k37_set(handle, addr, address);
	k37_set(handle, w_data, data);
	k37_set(handle, w_stb, 1);
	k37_step(handle, 1, 0);
	k37_set(handle, w_stb, 0);
}

// One host bus read cycle (sim/testbench.py bus_read); returns the byte of the next cycle.
uint64_t k37_bus_read(void *handle, size_t addr, size_t r_stb, size_t r_data, uint64_t address) {
	const size_t bus[] = {addr, r_stb, r_data};
	return bus_read(*static_cast<Model *>(handle), bus, address);
}

// The host's halted wait for an interrupt (`irq` reads non-zero after a cycle) with a timer
// routine that only reads (firmware_model.host.Host8085.wait_polling, whose own loop this is):
// at most `limit` cycles; at each tick (a multiple of `period`) that a wait reached without an
// interrupt, while `limit` had not run out, routine k (of `routines`) idles idles[k (n + 1) + j]
// cycles before reading port j (of n; the bus is addr, r_stb, r_data), then idles[k (n + 1) + n]
// after. Idle cycles are stepped as k37_step with `skip_idle`. With `due`, the first routine is
// due at once (a call that returned 3 was at its tick). Returns the routines run to their end;
// out[0] says why it returned: 0 an interrupt is pending after a wait, or `limit` ran out;
// 1 routine number (the return value) read a byte with a bit of its port's stops[j] set, its
// bytes in out[1 .. n] (its last idle cycles not run); 2 (come back: the same wait goes on)
// `pause` cycles have passed (the caller acts between cycles) or the routines ran out; 3 the
// same, at a tick whose routine is due (come back with `due`).
uint64_t k37_wait_polling(void *handle, size_t irq, const size_t *bus, uint64_t limit,
                          uint64_t pause, uint64_t period, const uint64_t *ports,
                          const uint64_t *stops, size_t n, const uint64_t *idles,
                          uint64_t routines, int due, int skip_idle, uint64_t *out) {
	Model &m = *static_cast<Model *>(handle);
	const Item &item = m.items[irq];
	const uint64_t start = m.cycle;
	for (uint64_t done = 0;; done++) {
		uint64_t to_tick = 0, waited = 1;
		while (!due && (waited != to_tick || m.cycle - start >= limit)) {
			// wait up to the next tick that comes before the limit
			uint64_t elapsed = m.cycle - start;
			out[0] = elapsed >= limit ? 0 : 2;
			if (elapsed >= limit || elapsed >= pause || done == routines)
				return done;
			to_tick = period - m.cycle % period;
			uint64_t wait = std::min(limit - elapsed, to_tick);
			bool paused = elapsed + wait > pause;
			waited = run_until(m, item, paused ? pause - elapsed : wait, skip_idle != 0);
			out[0] = 0;
			if (nonzero(m, item, is_state(item)))
				return done;
			out[0] = 2;
			if (paused)
				return done;
		}
		out[0] = 3;
		if (!due && m.cycle - start >= pause)
			return done;  // the routine of this tick is due: after the caller's pause
		due = false;
		const uint64_t *idle = idles + done * (n + 1);
		bool stop = false;
		for (size_t j = 0; j < n; j++) {
			step(m, idle[j], skip_idle != 0);
			out[1 + j] = bus_read(m, bus, ports[j]);
			stop |= (out[1 + j] & stops[j]) != 0;
		}
		if (stop) {
			out[0] = 1;
			return done;
		}
		step(m, idle[n], skip_idle != 0);
	}
}

// Declare a free-running phase accumulator (see Accumulator); returns its number, or -1 if
// phase or stb is not a register of at most 64 bits.
int k37_free_accumulator(void *handle, size_t phase, size_t increment, size_t stb,
                         unsigned width) {
	Model &m = *static_cast<Model *>(handle);
	for (size_t index : {phase, stb})
		if (!is_state(m.items[index]) || m.items[index].width > 64)
			return -1;
	if (width == 0 || width > 63 || m.items[increment].width > 64)
		return -1;
	m.accumulators.push_back(Accumulator{phase, increment, stb, width});
	return int(m.accumulators.size() - 1);
}

// Declare a counter of accumulator `clock`'s strobes (see StrobeCounter; gate SIZE_MAX: its
// pulses never matter); 0, or -1 if the items are not registers or `clock` is not declared.
int k37_free_counter(void *handle, size_t count, size_t select, unsigned width, size_t clock,
                     size_t word, size_t gate) {
	Model &m = *static_cast<Model *>(handle);
	for (size_t index : {count, select})
		if (!is_state(m.items[index]) || m.items[index].width > 64)
			return -1;
	if (width == 0 || width > 63 || clock >= m.accumulators.size())
		return -1;
	m.counters.push_back(StrobeCounter{count, select, width, clock, word, gate});
	return 0;
}

// Declare an accel/decel accumulator clocked by accumulator `clock` (see CarryAccumulator);
// 0, or -1 if y is not a register of n <= 63 bits or `clock` is not declared.
int k37_free_carry(void *handle, size_t y, size_t x, unsigned n, int x_signed, size_t clock) {
	Model &m = *static_cast<Model *>(handle);
	if (!is_state(m.items[y]) || m.items[y].width != n || n == 0 || n > 40 ||
	    m.items[x].width > 63 || clock >= m.accumulators.size())
		return -1;
	m.carries.push_back(CarryAccumulator{y, x, n, x_signed != 0, clock});
	return 0;
}

// Declare a servo plant (see Plant); 0, or -1 if velocity or before is not a register, or
// they are not as wide as the format says (the position, before, must be the 64 bits that
// the native steps compute in).
int k37_free_plant(void *handle, const size_t *items, unsigned vc_bits, unsigned alpha_bits,
                   unsigned frac_bits) {
	Model &m = *static_cast<Model *>(handle);
	Plant p{items[0], items[1], items[2], items[3], items[4], items[5], items[6], items[7],
	        vc_bits, alpha_bits, frac_bits};
	if (!is_state(m.items[p.velocity]) || m.items[p.velocity].width != vc_bits + 1 ||
	    !is_state(m.items[p.before]) || m.items[p.before].width != 64)
		return -1;
	m.plants.push_back(p);
	return 0;
}

// Declare a countdown (see Countdown); 0, or -1 if count is not a register of <= 64 bits.
int k37_free_countdown(void *handle, size_t count, uint64_t stop) {
	Model &m = *static_cast<Model *>(handle);
	if (!is_state(m.items[count]) || m.items[count].width > 64)
		return -1;
	m.countdowns.push_back(Countdown{count, stop});
	return 0;
}

// Declare the item that reads non-zero when the free-running state affects nothing else.
void k37_free_quiet(void *handle, size_t index) {
	static_cast<Model *>(handle)->quiet = index;
}

// Record items[0 .. n) (of at most 64 bits each) at every later multiple of `every` cycles
// (every >= 1), as the clock reaches it, until the model is destroyed (taken by k37_recorded).
void k37_record(void *handle, const size_t *items, size_t n, uint64_t every) {
	Model &m = *static_cast<Model *>(handle);
	bool outputs = std::all_of(items, items + n, [&](size_t index) {
		const Item &item = m.items[index];
		return is_state(item) || (item.flags & cxxrtl::debug_item::OUTPUT &&
		                          item.parts.size() == 1 && !item.parts.front().outline);
	});
	m.recorder = Recorder{std::vector<size_t>(items, items + n), outputs, every,
	                      (m.cycle / every + 1) * every, {}};
}

// The samples recorded and not yet taken: rows of the cycle and each item's value. Moves up
// to `size` words into `out` (they are taken: the recorder holds only what was not) and
// returns the number of words held before the call.
size_t k37_recorded(void *handle, uint64_t *out, size_t size) {
	std::vector<uint64_t> &rows = static_cast<Model *>(handle)->recorder.rows;
	size_t held = rows.size(), taken = std::min(size, held);
	std::copy_n(rows.begin(), taken, out);
	rows.erase(rows.begin(), rows.begin() + taken);
	return held;
}

// A self-check of k37_eval_skip (for tests): whether, from the current state, it computes
// items[0 .. n) (of one part each) as a settle does: 1 or 0; -1 if the model has none. It
// leaves the design settled.
int k37_check_eval_skip(void *handle, const size_t *items, size_t n) {
	Model &m = *static_cast<Model *>(handle);
	if (!m.has_eval_skip)
		return -1;
	mark_stale(m);
	refresh_skip_values(m);
	std::vector<uint64_t> fast;
	for (size_t i = 0; i < n; i++)
		fast.push_back(read_u64(m, items[i]));
	settle(m);
	for (size_t i = 0; i < n; i++)
		if (read_u64(m, items[i]) != fast[i])
			return 0;
	return 1;
}

int k37_falling_edge(void *handle) {
	return static_cast<Model *>(handle)->falling_edge;
}

uint64_t k37_cycle(void *handle) {
	return static_cast<Model *>(handle)->cycle;
}

uint64_t k37_skipped(void *handle) {
	return static_cast<Model *>(handle)->skipped;
}

// Record a VCD of cycles [start, stop) to `path`, scopes prefixed by `scope` ("bench top "):
// every item, or (`keep` not null) the items it names, one a line, scope included.
int k37_trace(void *handle, const char *path, const char *scope, const char *keep,
              uint64_t start, uint64_t stop, uint64_t quarter_period_fs) {
	Model &m = *static_cast<Model *>(handle);
	close_trace(m);
	FILE *file = fopen(path, "wb");
	if (!file)
		return -1;
	m.trace.reset(new Trace{{}, {}, file, start, stop, quarter_period_fs, false});
	m.top->debug_info(&m.trace->items, nullptr, scope);
	if (keep) {
		std::set<std::string> names;
		std::istringstream lines(keep);
		for (std::string line; std::getline(lines, line);)
			names.insert(line);
		auto &table = m.trace->items.table;
		for (auto it = table.begin(); it != table.end();)
			it = names.count(it->first) ? std::next(it) : table.erase(it);
	}
	m.trace->writer.timescale(1, "fs");
	m.trace->writer.add_without_memories(m.trace->items);
	settle(m);
	m.inputs_written = false;
	if (tracing(m))
		sample(*m.trace, input_time(m.cycle));
	return 0;
}

void k37_trace_close(void *handle) {
	close_trace(*static_cast<Model *>(handle));
}

}  // extern "C"
