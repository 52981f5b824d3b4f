// A C ABI over one Verilator model of an exported block, for ctypes (see sim/verilator.py).
//
// Compiled together with the design's Verilated C++ (class Vtop) and "ports.h", which lists
// the top module's ports as K37_PORT(name, is_input, width) lines, generated from Vtop.h.
// Ports are reached by their index in that list; values up to 64 bits.
//
// Clocking follows Amaranth's simulator with `add_clock` (and sim/cxxrtl_harness.cc): the
// clock starts low, the first cycle is a rising edge only, every later cycle is a falling edge
// then a rising edge (a negedge domain clocked from `clk` runs on the falling edge), so inputs
// set between steps are seen by the falling edge first. After a step the design is settled
// on its post-edge values, as after `await ctx.tick()`; reading an output after setting an
// input evaluates the combinational paths first.

#include "Vtop.h"
#include "verilated.h"

#include <cstdint>
#include <cstring>

namespace {

struct Port {
	const char *name;
	int is_input;
	int width;
};

const Port PORTS[] = {
#define K37_PORT(name, is_input, width) {#name, is_input, width},
#include "ports.h"
#undef K37_PORT
};
constexpr size_t COUNT = sizeof(PORTS) / sizeof(PORTS[0]);

struct Model {
	VerilatedContext context;
	Vtop *top;
	void *data[COUNT];
	size_t size[COUNT];
	uint64_t cycle = 0;
	bool dirty = true;

	Model() : top(new Vtop{&context}) {
		size_t i = 0;
#define K37_PORT(name, is_input, width) data[i] = &top->name; size[i++] = sizeof(top->name);
#include "ports.h"
#undef K37_PORT
	}
	~Model() {
		top->final();
		delete top;
	}
	void settle() {
		if (dirty) {
			top->eval();
			dirty = false;
		}
	}
};

}  // namespace

extern "C" {

void *k37v_create() {
	auto *m = new Model;
	m->top->clk = 0;
	m->top->eval();
	m->dirty = false;
	return m;
}

void k37v_destroy(void *h) { delete static_cast<Model *>(h); }

size_t k37v_count() { return COUNT; }

const char *k37v_name(size_t i) { return PORTS[i].name; }

int k37v_width(size_t i) { return PORTS[i].width; }

int k37v_is_input(size_t i) { return PORTS[i].is_input; }

void k37v_set(void *h, size_t i, uint64_t value) {
	auto *m = static_cast<Model *>(h);
	std::memcpy(m->data[i], &value, m->size[i]);  // little-endian: the low bytes
	m->dirty = true;
}

uint64_t k37v_get(void *h, size_t i) {
	auto *m = static_cast<Model *>(h);
	m->settle();
	uint64_t value = 0;
	std::memcpy(&value, m->data[i], m->size[i]);
	return value;
}

void k37v_step(void *h, uint64_t n) {
	auto *m = static_cast<Model *>(h);
	Vtop *top = m->top;
	for (uint64_t k = 0; k < n; k++) {
		if (top->clk) {
			top->clk = 0;
			top->eval();
		}
		top->clk = 1;
		top->eval();
	}
	m->cycle += n;
	m->dirty = false;
}

uint64_t k37v_cycle(void *h) { return static_cast<Model *>(h)->cycle; }

}  // extern "C"
