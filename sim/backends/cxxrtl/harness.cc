// A C ABI over one CXXRTL model, for ctypes (see sim/backends/cxxrtl/backend.py).
//
// The harness does not depend on the design, so it is compiled once per toolchain and linked
// with each design's object, which defines k37_make_top() (the output of `write_cxxrtl` for
// top module "top" plus a factory). Every named signal is reached through CXXRTL's debug items:
// ports and probes are items, found by index.
//
// This file is the harness's C ABI over the model: making it, reading and writing items,
// stepping, waiting, bus cycles, recording and the waveform. The rest is in parts, each with
// the C ABI of its own concern, that this file includes to make one translation unit (so that
// the compiler inlines across them as within one file; their definitions are internal to it):
//   model.h, model.cc  the model: its items, clock cycles, waveform, recorder and bus cycles;
//   skip.h, skip.cc    idle skipping: the free-running state advanced in closed form;
//   plant.h, plant.cc  the servo plants, stepped natively during a skip (lag.h: their update);
//   wait.h, wait.cc    the firmware's polling wait, run natively.
// build.py compiles this file alone, and keys its object by every part.

#include <algorithm>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "model.h"

#include "model.cc"
#include "plant.cc"
#include "skip.cc"
#include "wait.cc"

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

// One host bus write cycle (k37.sim.backends.contract.Backend.bus_write): the byte is taken at
// the edge.
void k37_bus_write(void *handle, size_t addr, size_t w_data, size_t w_stb, uint64_t address,
                   uint64_t data) {
	k37_set(handle, addr, address);
	k37_set(handle, w_data, data);
	k37_set(handle, w_stb, 1);
	k37_step(handle, 1, 0);
	k37_set(handle, w_stb, 0);
}

// One host bus read cycle (k37.sim.backends.contract.Backend.bus_read); returns the byte of the
// next cycle.
uint64_t k37_bus_read(void *handle, size_t addr, size_t r_stb, size_t r_data, uint64_t address) {
	const size_t bus[] = {addr, r_stb, r_data};
	return bus_read(*static_cast<Model *>(handle), bus, address);
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
