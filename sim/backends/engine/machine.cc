// The engine's C ABI, which the Python backend (backend.py) loads: a machine (machine.h) made
// and destroyed, its ports read and written, its cycles run (stepped, or skipped where it is
// quiet), a wait for a port, the host's bus cycles and polling wait, and samples recorded as
// the clock reaches them; and the machine's port accessors (Machine::get, Machine::set).

#include <ctime>

#include "machine.h"

namespace k37e {

uint64_t Machine::get(int port) const {
	if (port >= DRIVE_PORT_BASE)
		return axis[(port - DRIVE_PORT_BASE) / DRIVE_PORT_COUNT]
		    .plant.port[(port - DRIVE_PORT_BASE) % DRIVE_PORT_COUNT];
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
	case PERIOD: return a.in.period;
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

void Machine::set(int port, uint64_t v) {
	if (port >= DRIVE_PORT_BASE) {
		int k = (port - DRIVE_PORT_BASE) / DRIVE_PORT_COUNT;
		forget(k, axis[k].ctrl.dac);
		axis[k].plant.port[(port - DRIVE_PORT_BASE) % DRIVE_PORT_COUNT] = v;
		return;
	}
	switch (port) {
	case BUS_ADDR: addr = v; return;
	case BUS_W_STB: w_stb = v; return;
	case BUS_W_DATA: w_data = v; return;
	case BUS_R_STB: r_stb = v; return;
	}
	if (port < TOP_COUNT)
		return;
	int k = (port - TOP_COUNT) / AXIS_COUNT;
	forget(k, axis[k].ctrl.dac);  // the plant's inputs change
	PlantInputs &in = axis[k].in;
	switch ((port - TOP_COUNT) % AXIS_COUNT) {
	case GAIN: in.gain = v; return;
	case ALPHA: in.alpha = v; return;
	case VMAX: in.vmax = v; return;
	case KF: in.kf = v; return;
	case PERIOD: in.period = v; return;
	case DAC_ZERO: in.dac_zero = v; return;
	case STALL: in.stall = v; return;
	case GLITCH_A: in.glitch_a = v; return;
	case GLITCH_B: in.glitch_b = v; return;
	case BREAK_A: in.break_a = v; return;
	}
}

// Run up to n cycles, skipping where the machine is quiet, and stop after the cycle at whose
// end `port` (-1: none) reads non-zero; the cycles run. Where it is not quiet, the machine
// steps. Where it is, each stretch runs the plants and the encoder interfaces alone
// (advance_plants) and the chips' free-running state in closed form (advance_free) up to
// and including the cycle of the chips' next event (horizon), whose edge the chips then take
// alone (rise_chips: in it the axes take no command pulse); or up to the cycle in which an
// encoder interface's filter passes a change, whose count pulse the K3702 takes at the next
// falling edge, the start of the next stretch; or up to the next sample. Between events only
// the plants, the encoders' filter streaks and the free-running state move, so the port is
// read after each event. `skipped` counts the cycles in which none comes and no K3702 falls.
uint64_t Machine::run(uint64_t n, int port) {
	uint64_t done = 0, h = 0;
	bool known = false;             // h is the horizon of the machine as it is
	bool settled = axes_settled();  // and so the axes stay through the run (inputs held)
	bool quiet = settled && chips_alone() && !pulsed();
	// The stretch starts with a falling edge; it is the last (the port reads non-zero already).
	bool fell = false, last = port >= 0 && get(port);
	while (done < n) {
		if (!quiet) {
			step();
			done++;
			if (port >= 0 && get(port))
				return done;
			settled = settled || axes_settled();
			quiet = settled && chips_alone() && !pulsed();
			known = false;
			continue;
		}
		if (!known)
			h = horizon();
		uint64_t len = last ? 1 : std::min(n - done, next_sample - cycle);
		bool event = h < len;  // the event's cycle, h + 1, ends the stretch
		if (event)
			len = h + 1;
		uint64_t k = advance_plants(len);
		bool chips = event && k == len;
		if (k > uint64_t(chips))
			advance_free(k - chips);
		if (chips)
			rise_chips();
		skipped += k - std::min<uint64_t>(k, uint64_t(chips) + fell);
		count_cycles(k);
		if (chips)
			renew(cycle);
		done += k;
		if (last || (chips && port >= 0 && get(port)))
			return done;
		quiet = !chips || chips_alone();  // the chips change only at an event
		known = !chips;
		h -= known ? k : 0;
		fell = pulsed() && quiet && done < n;
		if (fell) {
			fall();
			for (int i = 0; i < axes; i++)  // taken: the next rise recomputes them
				axis[i].enc.fb_pos = axis[i].enc.fb_neg = false;
			last = port >= 0 && get(port);
		} else {
			quiet = quiet && !pulsed();
		}
	}
	return done;
}

// Run n cycles; with skip_idle, skipping where the machine is quiet.
void run(Machine &m, uint64_t n, bool skip_idle) {
	if (skip_idle) {
		m.run(n, -1);
		return;
	}
	for (uint64_t i = 0; i < n; i++)
		m.step();
}

// Step until `port` reads non-zero after a cycle, at most `limit` cycles; the cycles run.
uint64_t run_until(Machine &m, int port, uint64_t limit, bool skip_idle) {
	if (skip_idle)
		return m.run(limit, port);
	for (uint64_t i = 0; i < limit;) {
		m.step();
		i++;
		if (m.get(port))
			return i;
	}
	return limit;
}

uint64_t bus_read(Machine &m, uint64_t addr) {
	m.addr = addr;
	m.r_stb = true;
	m.step();
	m.r_stb = false;
	return m.r_data();
}

// Why wait_polling returned (the compiled RTL backend's WaitEnd, value for value).
enum WaitEnd : int { OVER = 0, STOPPED = 1, PAUSED = 2, PAUSED_DUE = 3 };

// The host's halted wait for an interrupt with a timer routine that only reads, as
// k37.firmware_model.host.Host8085.wait_polling's own loop runs it (the contract's
// Backend.wait_polling tells each argument and result).
int wait_polling(Machine &m, int irq, uint64_t limit, uint64_t pause, uint64_t period,
                 const uint64_t *ports, const uint64_t *stops, size_t n, const uint64_t *idles,
                 uint64_t routines, bool due, bool skip_idle, uint64_t &done, uint64_t *bytes) {
	const uint64_t start = m.cycle;
	for (done = 0;; done++) {
		uint64_t to_tick = 0, waited = 1;
		while (!due && (waited != to_tick || m.cycle - start >= limit)) {
			uint64_t elapsed = m.cycle - start;
			if (elapsed >= limit)
				return OVER;
			if (elapsed >= pause || done == routines)
				return PAUSED;
			to_tick = period - m.cycle % period;
			uint64_t wait = std::min(limit - elapsed, to_tick);
			bool paused = elapsed + wait > pause;
			waited = run_until(m, irq, paused ? pause - elapsed : wait, skip_idle);
			if (m.get(irq))
				return OVER;
			if (paused)
				return PAUSED;
		}
		if (!due && m.cycle - start >= pause)
			return PAUSED_DUE;
		due = false;
		const uint64_t *idle = idles + done * (n + 1);
		bool stop = false;
		for (size_t j = 0; j < n; j++) {
			run(m, idle[j], skip_idle);
			bytes[j] = bus_read(m, ports[j]);
			stop |= (bytes[j] & stops[j]) != 0;
		}
		if (stop)
			return STOPPED;
		run(m, idle[n], skip_idle);
	}
}

}  // namespace k37e

using k37e::Machine;

// Only the C ABI is exported (the library is built with hidden visibility): calls inside the
// engine are then direct and inlined, never through the dynamic linker's table.
#pragma GCC visibility push(default)
extern "C" {

// A machine of `axes` axes with its accel/decel circuits placed at `placement` (0 none, 1 pre,
// 2 post): shapes[0] and bits[0] the circuit's before the K3701, shapes[1 + k] and bits[1 + k]
// axis k's after it (shapes: 0 exponential, 1 linear, 2 bell); bit k of `fa_axes` set if axis
// k's circuit has an addition clock of its own.
void *k37e_create(int axes, int placement, const int *shapes, const unsigned *bits,
                  unsigned fa_axes) {
	return new Machine(axes, k37e::Placement(placement),
	                   {shapes[0], shapes[1], shapes[2], shapes[3]}, {bits[0], bits[1], bits[2], bits[3]},
	                   fa_axes);
}
void k37e_destroy(void *m) { delete static_cast<Machine *>(m); }

// The index of the port `name` (-1: the engine has no such port).
int k37e_port(const char *name) {
	for (int i = 0; i < k37e::TOP_COUNT; i++)
		if (!strcmp(name, k37e::TOP_PORTS[i]))
			return i;
	const char *axes[] = {"x__", "y__", "z__"};
	for (int k = 0; k < k37e::MAX_AXES; k++)
		if (!strncmp(name, axes[k], 3))
			for (int i = 0; i < k37e::AXIS_COUNT; i++)
				if (!strcmp(name + 3, k37e::AXIS_PORTS[i]))
					return k37e::TOP_COUNT + k * k37e::AXIS_COUNT + i;
	for (int k = 0; k < k37e::MAX_AXES; k++)
		if (!strncmp(name, axes[k], 3))
			for (int i = 0; i < k37e::DRIVE_PORT_COUNT; i++)
				if (!strcmp(name + 3, k37e::DRIVE_PORTS[i]))
					return k37e::DRIVE_PORT_BASE + k * k37e::DRIVE_PORT_COUNT + i;
	return -1;
}

// Axis k's drive: 0 the first-order plant, 1 the torque drive, 2 the two-mass drive
// (k37e::DriveKind); every axis's is first-order until set.
void k37e_drive(void *m, int axis, int kind) { static_cast<Machine *>(m)->set_drive(axis, kind); }

uint64_t k37e_get(void *m, int port) { return static_cast<Machine *>(m)->get(port); }
void k37e_set(void *m, int port, uint64_t v) { static_cast<Machine *>(m)->set(port, v); }

void k37e_get_many(void *m, const int *ports, size_t n, uint64_t *out) {
	for (size_t i = 0; i < n; i++)
		out[i] = static_cast<Machine *>(m)->get(ports[i]);
}

// The internal signal at `path` (the RTL's name), of those the engine has: the K3701's busy
// and overrun flags, and the accel/decel circuit's idle before it; 0 with its value in *value, or -1 if the
// engine has no such signal in this machine.
int k37e_probe(void *m, const char *path, uint64_t *value) {
	const Machine &machine = *static_cast<Machine *>(m);
	if (!strcmp(path, "chipset.k3701.busy"))
		*value = machine.interp.out.busy;
	else if (!strcmp(path, "chipset.k3701.overrun"))
		*value = machine.interp.out.overrun;
	else if (!strcmp(path, "chipset.accel.idle") && machine.accel_pre)
		*value = machine.accel.idle();
	else
		return -1;
	return 0;
}

uint64_t k37e_cycle(void *m) { return static_cast<Machine *>(m)->cycle; }
uint64_t k37e_skipped(void *m) { return static_cast<Machine *>(m)->skipped; }

void k37e_step(void *m, uint64_t n, int skip_idle) {
	k37e::run(*static_cast<Machine *>(m), n, skip_idle);
}

uint64_t k37e_run_until(void *m, int port, uint64_t limit, int skip_idle) {
	return k37e::run_until(*static_cast<Machine *>(m), port, limit, skip_idle);
}

int k37e_wait_polling(void *m, int irq, uint64_t limit, uint64_t pause, uint64_t period,
                      const uint64_t *ports, const uint64_t *stops, size_t n,
                      const uint64_t *idles, uint64_t routines, int due, int skip_idle,
                      uint64_t *done, uint64_t *bytes) {
	return k37e::wait_polling(*static_cast<Machine *>(m), irq, limit, pause, period, ports, stops,
	                          n, idles, routines, due, skip_idle, *done, bytes);
}

// Record `ports` at every later multiple of `every` cycles (every >= 1).
void k37e_record(void *m, const int *ports, size_t n, uint64_t every) {
	Machine &machine = *static_cast<Machine *>(m);
	machine.record_ports.assign(ports, ports + n);
	machine.every = every;
	machine.next_sample = (machine.cycle / every + 1) * every;
	machine.rows.clear();
}

// The samples recorded and not yet taken (rows of the cycle and each port): moves up to
// `size` words into `out` and returns the number of words held before the call.
size_t k37e_recorded(void *m, uint64_t *out, size_t size) {
	std::vector<uint64_t> &rows = static_cast<Machine *>(m)->rows;
	size_t held = rows.size(), taken = std::min(size, held);
	std::copy_n(rows.begin(), taken, out);
	rows.erase(rows.begin(), rows.begin() + taken);
	return held;
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
	return k37e::bus_read(*static_cast<Machine *>(m), addr);
}

// The closed forms of free.h, for tests that pin them to the reference models.
uint64_t k37e_clocks_before_pulse(uint64_t count, uint64_t word, unsigned width) {
	return k37e::clocks_before_pulse(count, word, width);
}
uint64_t k37e_cycles_within(uint64_t phase, uint64_t increment, int stb, unsigned width,
                            uint64_t safe) {
	return k37e::cycles_within(phase, increment, stb, width, safe);
}
uint64_t k37e_strobes_seen(uint64_t phase, uint64_t increment, int stb, unsigned width,
                           uint64_t k) {
	return k37e::strobes_seen(phase, increment, stb, width, k);
}

// The lazy plant's bound (Lag::clear: the cycles that surely keep the count) and its run of
// k cycles known to keep the count (Lag::run, into *v and *position), for tests that pin them
// to the plant's model; v, vc and position as lag.h keeps them.
uint64_t k37e_lag_clear(int64_t v, int64_t vc, int64_t alpha, uint64_t position, int stall) {
	return k37lag::Lag(v, vc, alpha, position, stall, k37e::VC_BITS, k37e::ALPHA_BITS,
	                   k37e::FRAC_BITS)
	    .clear();
}
void k37e_lag_run(int64_t *v, int64_t vc, int64_t alpha, uint64_t *position, int stall,
                  uint64_t k) {
	k37lag::Lag lag(*v, vc, alpha, *position, stall, k37e::VC_BITS, k37e::ALPHA_BITS,
	                k37e::FRAC_BITS);
	lag.run(k);
	*v = lag.v;
	*position = lag.position;
}

// CPU nanoseconds per cycle of one plant stepped `cycles` times at a changing D/A word (the
// cost of stepping a plant per axis and cycle, for the performance page).
double k37e_plant_ns(uint64_t cycles) {
	k37e::Plant plant;
	k37e::PlantInputs in;
	in.gain = 1 << 20;
	in.alpha = 1 << 14;
	in.dac_zero = 2048;
	timespec start, stop;
	clock_gettime(CLOCK_THREAD_CPUTIME_ID, &start);
	for (uint64_t i = 0; i < cycles; i++)
		plant.rise(in, 2048 + (i >> 6 & 15), 0);
	clock_gettime(CLOCK_THREAD_CPUTIME_ID, &stop);
	volatile int64_t sink = plant.velocity;
	(void)sink;
	return (double(stop.tv_sec - start.tv_sec) * 1e9 + double(stop.tv_nsec - start.tv_nsec)) /
	       double(cycles);
}

}  // extern "C"
#pragma GCC visibility pop
