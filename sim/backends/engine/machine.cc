// The engine's machine: the two-axis chipset (FEED, DECEL, the exponential accel/decel circuit
// before the K3701 or none, the K3701, a K3702 and an encoder interface per axis, the host bus
// decoding) with a first-order plant per axis and the observation counters, composed as
// k37.sim.machine.system.System and k37.hdl.chipset.chip.Chipset wire them; its ports by the
// System's names, its cycles (a falling edge, except in the first, then a rising edge, as
// Amaranth's simulator clocks it), and the C ABI that the Python backend (backend.py) loads.

#include <chrono>
#include <cstring>
#include <string>

#include "blocks.h"
#include "k3701.h"

namespace k37e {

constexpr int AXES = 2;

// Every port, by the System's name (a bus member, a top output or an axis's member).
const char *const TOP_PORTS[] = {"bus__addr", "bus__w_stb", "bus__w_data", "bus__r_stb",
                                 "bus__r_data", "irq", "irq_interp", "irq_alarm", "fp_total",
                                 "quiet"};
enum TopPort { BUS_ADDR, BUS_W_STB, BUS_W_DATA, BUS_R_STB, BUS_R_DATA, IRQ, IRQ_INTERP,
               IRQ_ALARM, FP_TOTAL, QUIET, TOP_COUNT };
const char *const AXIS_PORTS[] = {"gain", "alpha", "vmax", "kf", "dac_zero", "stall",
                                  "glitch_a", "glitch_b", "break_a", "command", "error", "count",
                                  "dac", "max_abs_error", "pulses_pos", "pulses_neg", "alarm_n"};
enum AxisPort { GAIN, ALPHA, VMAX, KF, DAC_ZERO, STALL, GLITCH_A, GLITCH_B, BREAK_A, COMMAND,
                ERROR, COUNT, DAC, MAX_ABS_ERROR, PULSES_POS, PULSES_NEG, ALARM_N, AXIS_COUNT };
constexpr int PORT_COUNT = TOP_COUNT + AXES * AXIS_COUNT;

struct Axis {
	K3702 ctrl;
	Encoder enc;
	Plant plant;
	PlantInputs in;
	uint64_t max_abs_error = 0;
	uint32_t pulses_pos = 0, pulses_neg = 0;
};

struct Machine {
	bool accel_pre = true;
	Feed feed;
	Decel decel;
	Accel accel;
	K3701 interp;
	Axis axis[AXES];
	uint64_t addr = 0, w_data = 0;
	bool w_stb = false, r_stb = false;
	unsigned read_cs = 0;
	uint32_t fp_total = 0;
	uint64_t cycle = 0;

	Machine(bool pre, unsigned accel_bits) : accel_pre(pre) {
		accel.n = accel_bits;
		feed.bank.init(FEED_REGS, FEED_REG_COUNT);
		decel.bank.init(DECEL_REGS, DECEL_REG_COUNT);
		interp.bank.init(K3701_REGS, K3701_REG_COUNT);
		for (Axis &a : axis) {
			a.ctrl.bank.init(K3702_REGS, K3702_REG_COUNT);
			a.enc.bank.init(ENCODER_REGS, ENCODER_REG_COUNT);
		}
	}
	// The decel gate's output and the interpolator's FP in this cycle (combinational).
	bool decel_out() const { return feed.out() && decel.gate_open(); }
	bool fp() const { return accel_pre ? accel.out() : decel_out(); }
	bool irq_alarm() const { return axis[0].ctrl.irq || axis[1].ctrl.irq; }
	bool quiet() const { return interp.quiet(fp()) && (!accel_pre || accel.pending == 0); }
	uint8_t r_data() const {
		switch (read_cs) {
		case SELECT_K3701: return interp.bank.r_data;
		case SELECT_K3702_X: return axis[0].ctrl.bank.r_data;
		case SELECT_K3702_Y: return axis[1].ctrl.bank.r_data;
		case SELECT_ENCODER_X: return axis[0].enc.bank.r_data;
		case SELECT_ENCODER_Y: return axis[1].enc.bank.r_data;
		case SELECT_FEED: return feed.bank.r_data;
		case SELECT_DECEL: return decel.bank.r_data;
		default: return 0;
		}
	}

	// One chip's bank edge: its strobes where the address selects it (no aliases: the
	// address bits between the chip's map and the select must be 0).
	template<class Chip>
	BankEdge decode(const Chip &chip, unsigned select, unsigned width) const {
		bool hit = (addr >> REG_BITS) == select && (addr & low_bits(REG_BITS)) >> width == 0;
		return chip.bank.decode(w_stb && hit, r_stb && hit, unsigned(addr & low_bits(width)),
		                        uint8_t(w_data), [&](int reg) { return chip.read(reg); });
	}

	void fall() {
		for (int k = 0; k < AXES; k++) {
			const K3701Out &o = interp.out;
			int com = k == 0 ? int(o.x_pos) - int(o.x_neg) : int(o.y_pos) - int(o.y_neg);
			Axis &a = axis[k];
			a.ctrl.fall(com, int(a.enc.fb_pos) - int(a.enc.fb_neg));
		}
	}

	void rise() {
		// Everything the edge reads, from the values before it.
		bool gate = decel_out(), add = feed.fa(), feed_pulse = fp();
		BankEdge e_feed = decode(feed, SELECT_FEED, FEED_ADDR_WIDTH);
		BankEdge e_decel = decode(decel, SELECT_DECEL, DECEL_ADDR_WIDTH);
		BankEdge e_interp = decode(interp, SELECT_K3701, K3701_ADDR_WIDTH);
		BankEdge e_ctrl[AXES] = {decode(axis[0].ctrl, SELECT_K3702_X, K3702_ADDR_WIDTH),
		                         decode(axis[1].ctrl, SELECT_K3702_Y, K3702_ADDR_WIDTH)};
		BankEdge e_enc[AXES] = {decode(axis[0].enc, SELECT_ENCODER_X, ENCODER_ADDR_WIDTH),
		                        decode(axis[1].enc, SELECT_ENCODER_Y, ENCODER_ADDR_WIDTH)};
		const K3701Out steps = interp.out;
		int com[AXES] = {int(steps.x_pos) - int(steps.x_neg), int(steps.y_pos) - int(steps.y_neg)};
		// The edge.
		feed.rise();
		decel.rise(gate);
		if (accel_pre)
			accel.rise(gate, add);
		interp.rise(feed_pulse);
		for (int k = 0; k < AXES; k++) {
			Axis &a = axis[k];
			a.enc.rise(a.plant.lines());
			a.plant.rise(a.in, a.ctrl.dac, com[k]);
			uint64_t magnitude = uint64_t(a.ctrl.error < 0 ? -a.ctrl.error : a.ctrl.error);
			if (magnitude > a.max_abs_error)
				a.max_abs_error = magnitude;
			a.pulses_pos += com[k] > 0;
			a.pulses_neg += com[k] < 0;
		}
		fp_total += feed_pulse;
		if (r_stb)
			read_cs = unsigned(addr >> REG_BITS) & 7;
		feed.bank.apply(e_feed);
		decel.bank.apply(e_decel);
		interp.bank.apply(e_interp);
		for (int k = 0; k < AXES; k++) {
			axis[k].ctrl.bank.apply(e_ctrl[k]);
			axis[k].enc.bank.apply(e_enc[k]);
		}
	}

	void step() {
		if (cycle)
			fall();
		rise();
		cycle++;
	}

	uint64_t get(int port) const {
		if (port < TOP_COUNT) {
			switch (port) {
			case BUS_ADDR: return addr;
			case BUS_W_STB: return w_stb;
			case BUS_W_DATA: return w_data;
			case BUS_R_STB: return r_stb;
			case BUS_R_DATA: return r_data();
			case IRQ: return interp.out.irq || irq_alarm();
			case IRQ_INTERP: return interp.out.irq;
			case IRQ_ALARM: return irq_alarm();
			case FP_TOTAL: return fp_total;
			case QUIET: return quiet();
			}
		}
		const Axis &a = axis[(port - TOP_COUNT) / AXIS_COUNT];
		switch ((port - TOP_COUNT) % AXIS_COUNT) {
		case GAIN: return a.in.gain;
		case ALPHA: return a.in.alpha;
		case VMAX: return a.in.vmax;
		case KF: return a.in.kf;
		case DAC_ZERO: return a.in.dac_zero;
		case STALL: return a.in.stall;
		case GLITCH_A: return a.in.glitch_a;
		case GLITCH_B: return a.in.glitch_b;
		case BREAK_A: return a.in.break_a;
		case COMMAND: return uint64_t(a.ctrl.command) & low_bits(COUNTER_WIDTH);
		case ERROR: return uint64_t(a.ctrl.error) & low_bits(COUNTER_WIDTH);
		case COUNT: return uint32_t(a.plant.count());
		case DAC: return a.ctrl.dac;
		case MAX_ABS_ERROR: return a.max_abs_error;
		case PULSES_POS: return a.pulses_pos;
		case PULSES_NEG: return a.pulses_neg;
		case ALARM_N: return a.ctrl.alarm_n;
		}
		return 0;
	}

	void set(int port, uint64_t v) {
		switch (port) {
		case BUS_ADDR: addr = v; return;
		case BUS_W_STB: w_stb = v; return;
		case BUS_W_DATA: w_data = v; return;
		case BUS_R_STB: r_stb = v; return;
		}
		if (port < TOP_COUNT)
			return;
		PlantInputs &in = axis[(port - TOP_COUNT) / AXIS_COUNT].in;
		switch ((port - TOP_COUNT) % AXIS_COUNT) {
		case GAIN: in.gain = v; return;
		case ALPHA: in.alpha = v; return;
		case VMAX: in.vmax = v; return;
		case KF: in.kf = v; return;
		case DAC_ZERO: in.dac_zero = v; return;
		case STALL: in.stall = v; return;
		case GLITCH_A: in.glitch_a = v; return;
		case GLITCH_B: in.glitch_b = v; return;
		case BREAK_A: in.break_a = v; return;
		}
	}
};

}  // namespace k37e

using k37e::Machine;

extern "C" {

void *k37e_create(int accel_pre, unsigned accel_bits) { return new Machine(accel_pre, accel_bits); }
void k37e_destroy(void *m) { delete static_cast<Machine *>(m); }

// The index of the port `name` (-1: the engine has no such port).
int k37e_port(const char *name) {
	for (int i = 0; i < k37e::TOP_COUNT; i++)
		if (!strcmp(name, k37e::TOP_PORTS[i]))
			return i;
	const char *axes[] = {"x__", "y__"};
	for (int k = 0; k < k37e::AXES; k++)
		if (!strncmp(name, axes[k], 3))
			for (int i = 0; i < k37e::AXIS_COUNT; i++)
				if (!strcmp(name + 3, k37e::AXIS_PORTS[i]))
					return k37e::TOP_COUNT + k * k37e::AXIS_COUNT + i;
	return -1;
}

uint64_t k37e_get(void *m, int port) { return static_cast<Machine *>(m)->get(port); }
void k37e_set(void *m, int port, uint64_t v) { static_cast<Machine *>(m)->set(port, v); }

void k37e_get_many(void *m, const int *ports, size_t n, uint64_t *out) {
	for (size_t i = 0; i < n; i++)
		out[i] = static_cast<Machine *>(m)->get(ports[i]);
}

uint64_t k37e_cycle(void *m) { return static_cast<Machine *>(m)->cycle; }
// Whether a block the engine does not run (parabolic, exponential) was started.
int k37e_unsupported(void *m) { return static_cast<Machine *>(m)->interp.unsupported; }

void k37e_step(void *m, uint64_t n) {
	Machine &machine = *static_cast<Machine *>(m);
	for (uint64_t i = 0; i < n; i++)
		machine.step();
}

// Step until `port` reads non-zero after a cycle, at most `limit` cycles; the cycles run.
uint64_t k37e_run_until(void *m, int port, uint64_t limit) {
	Machine &machine = *static_cast<Machine *>(m);
	for (uint64_t i = 0; i < limit;) {
		machine.step();
		i++;
		if (machine.get(port))
			return i;
	}
	return limit;
}

// A host write cycle (as Backend.bus_write).
void k37e_bus_write(void *m, uint64_t addr, uint64_t data) {
	Machine &machine = *static_cast<Machine *>(m);
	machine.addr = addr;
	machine.w_data = data;
	machine.w_stb = true;
	machine.step();
	machine.w_stb = false;
}

// A host read cycle (as Backend.bus_read): the byte presented after it.
uint64_t k37e_bus_read(void *m, uint64_t addr) {
	Machine &machine = *static_cast<Machine *>(m);
	machine.addr = addr;
	machine.r_stb = true;
	machine.step();
	machine.r_stb = false;
	return machine.r_data();
}

// Nanoseconds per cycle of one plant stepped `cycles` times at a constant D/A word (the cost
// of stepping a plant per axis and cycle, for the performance page).
double k37e_plant_ns(uint64_t cycles) {
	k37e::Plant plant;
	k37e::PlantInputs in;
	in.gain = 1 << 20;
	in.alpha = 1 << 14;
	in.dac_zero = 2048;
	auto start = std::chrono::steady_clock::now();
	for (uint64_t i = 0; i < cycles; i++)
		plant.rise(in, 2048 + (i >> 6 & 15), 0);
	std::chrono::duration<double, std::nano> took = std::chrono::steady_clock::now() - start;
	volatile int64_t sink = plant.velocity;
	(void)sink;
	return took.count() / double(cycles);
}

}  // extern "C"
