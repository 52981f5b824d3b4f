// The model that the harness drives: what the design's object defines (the C++ that codegen.py
// generates around Yosys's, compiled per design by build.py), the design's items, the Model
// (the design and the harness's state of it), and the helpers with which every part of the
// harness evaluates the design and reads and writes its values; model.cc steps it. Part of the
// harness's one translation unit (harness.cc): its definitions are internal to it (an
// anonymous namespace).

#pragma once

#include <cxxrtl/cxxrtl.h>
#include <cxxrtl/cxxrtl_vcd.h>

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "plant.h"
#include "skip.h"

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

namespace {

constexpr unsigned CHANGED = 1, REST_CHANGED = 2;

using cxxrtl::chunk_t;
constexpr size_t CHUNK_BITS = 8 * sizeof(chunk_t);

using u128 = unsigned __int128;
using i128 = __int128;

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

// Samples of some items (of at most 64 bits) at every multiple of `every` cycles, taken as
// the clock reaches it (k37_record): settled, or outputs as the skip evaluation computes them.
struct Recorder {
	std::vector<size_t> items;
	bool outputs = false;  // every item is an output port or a register
	uint64_t every = 0, next = UINT64_MAX;
	std::vector<uint64_t> rows;  // per sample: the cycle, then each item's value
};

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
	std::vector<Lag> plant_states;
	std::vector<int64_t> plant_steps;
	std::vector<uint64_t> strobes;
};

// The state (or an input) changed: every combinational value may lag it, the skip's too.
inline void mark_stale(Model &m) {
	m.stale = true;
	m.skip_values = false;
}

// One clock edge, as CXXRTL's module::step(): evaluate and commit until converged; returns
// the commits' flags (CHANGED, REST_CHANGED). Combinational values computed from committed
// state are not recomputed, so they may lag until the next evaluation. `Rising` tells which
// edge this is, so that only the wires it can change are committed.
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

// Compute a settled part's value if CXXRTL outlined it (model.cc).
void eval_outline(Model &m, const Part &p);

// The value at `v` (a part's current or next chunks) of a part of at most 64 bits.
inline uint64_t word(const Part &p, const chunk_t *v) {
	return p.width > 32 ? uint64_t(v[1]) << 32 | v[0] : v[0];
}

inline __attribute__((always_inline)) uint64_t read_u64(Model &m, size_t index) {
	const Part &p = m.items[index].parts.front();
	eval_outline(m, p);
	return word(p, p.curr);
}

// Defined in model.cc, which tells what each does: reading and writing values,
bool is_state(const Item &item);
bool nonzero(Model &m, const Item &item, bool settled);
void write_state(Model &m, size_t index, uint64_t value);
void set_port(Model &m, size_t index, uint64_t value);
int64_t sign_extend(uint64_t raw, size_t width);
// stepping, waiting and bus cycles,
void count_cycles(Model &m, uint64_t n);
void step(Model &m, uint64_t n, bool skip_idle);
uint64_t run_until(Model &m, const Item &item, uint64_t limit, bool skip_idle);
uint64_t bus_read(Model &m, const size_t *bus, uint64_t address);
// the waveform.
bool tracing(const Model &m);
uint64_t input_time(uint64_t c);
void sample(Trace &t, uint64_t quarters);
void close_trace(Model &m);

}  // namespace
