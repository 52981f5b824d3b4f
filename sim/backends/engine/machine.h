// The engine's machine: the two- or three-axis chipset (FEED, DECEL, an accel/decel circuit
// of any shape before the K3701, one per axis after it, or none; the K3701, a K3702 and an
// encoder interface per axis, the host bus decoding) with a servo drive per axis and
// the observation counters, composed as k37.sim.machine.system.System and
// k37.hdl.chipset.chip.Chipset wire them; its ports by the System's names; its cycles (a falling edge, except in the first, then a rising edge, as
// Amaranth's simulator clocks it); and its idle skipping: while nothing but the free-running
// state (the dividers, the rate multiplier's counter, the accel/decel accumulator, the K3701's
// latency or setup count), the plants and the encoder filters' streaks change, cycles are
// advanced in closed form up to the next event, the plants run alone (axes.h), exactly as
// stepping the whole machine would; the chips' events that give the axes no command pulse
// (an accel/decel output pulse before the K3701 among them) and the K3702s' counts of
// encoder pulses are taken there alone (Machine::run).

#pragma once

#include <algorithm>
#include <cstring>
#include <utility>
#include <vector>

#include "axes.h"
#include "free.h"
#include "k3701.h"

namespace k37e {

// Every port, by the System's name (a bus member, a top output or an axis's member).
const char *const TOP_PORTS[] = {"bus__addr", "bus__w_stb", "bus__w_data", "bus__r_stb",
                                 "bus__r_data", "irq", "irq_interp", "irq_alarm", "fp_total",
                                 "quiet"};
enum TopPort { BUS_ADDR, BUS_W_STB, BUS_W_DATA, BUS_R_STB, BUS_R_DATA, IRQ, IRQ_INTERP,
               IRQ_ALARM, FP_TOTAL, QUIET, TOP_COUNT };
const char *const AXIS_PORTS[] = {"gain", "alpha", "vmax", "kf", "period", "dac_zero", "stall",
                                  "glitch_a", "glitch_b", "break_a", "command", "error", "count",
                                  "dac", "max_abs_error", "pulses_pos", "pulses_neg", "alarm_n"};
enum AxisPort { GAIN, ALPHA, VMAX, KF, PERIOD, DAC_ZERO, STALL, GLITCH_A, GLITCH_B, BREAK_A, COMMAND,
                ERROR, COUNT, DAC, MAX_ABS_ERROR, PULSES_POS, PULSES_NEG, ALARM_N, AXIS_COUNT };
// The drives' inputs (drives.h, DRIVE_PORTS) are numbered after every axis's ports.
constexpr int DRIVE_PORT_BASE = TOP_COUNT + MAX_AXES * AXIS_COUNT;
constexpr int PORT_COUNT = DRIVE_PORT_BASE + MAX_AXES * DRIVE_PORT_COUNT;

// Where the accel/decel circuit is (k37.hdl.chipset.map.Accel): before the K3701, one per
// axis after it, or none.
enum class Placement { NONE, PRE, POST };

struct Machine : Axes {
	const Placement placement;
	const bool accel_pre, accel_post;
	Feed feed;
	Decel decel;
	Circuit accel;  // before the K3701 (pre placement)
	K3701 interp;
	uint64_t addr = 0, w_data = 0;
	bool w_stb = false, r_stb = false;
	unsigned read_cs = 0;
	bool read_a4 = false;  // select 7's window of the last read (three axes)
	bool strobed = false;  // a bank holds a strobe (committed or refused) of the last edge
	uint32_t fp_total = 0;
	uint64_t cycle = 0, skipped = 0;
	// Samples of some ports at every multiple of `every` cycles (k37e_record): each row the
	// cycle and the ports' values; a skip's stretch ends at the next sample.
	std::vector<int> record_ports;
	uint64_t every = 0, next_sample = UINT64_MAX;
	std::vector<uint64_t> rows;

	// `shapes` and `bits`: the circuit before the K3701's, then each axis's (Circuit::Shape).
	// `fa_axes`: bit k set if axis k's circuit has an addition clock of its own.
	Machine(int chip_axes, Placement where, const int (&shapes)[1 + MAX_AXES],
	        const unsigned (&bits)[1 + MAX_AXES], unsigned fa_axes)
	    : Axes(chip_axes), placement(where), accel_pre(where == Placement::PRE),
	      accel_post(where == Placement::POST) {
		accel.init(shapes[0], bits[0], false);
		for (int k = 0; k < MAX_AXES; k++)
			axis[k].post.init(shapes[1 + k], bits[1 + k], true);
		feed.init(fa_axes);
		decel.bank.init(DECEL_REGS, DECEL_REG_COUNT);
		interp.init(axes);
		for (Axis &a : axis) {
			a.ctrl.bank.init(K3702_REGS, K3702_REG_COUNT);
			a.enc.bank.init(ENCODER_REGS, ENCODER_REG_COUNT);
		}
	}
	// The decel gate's output and the interpolator's FP in this cycle (combinational).
	bool decel_out() const { return feed.out() && decel.gate_open(); }
	bool fp() const { return accel_pre ? accel.out() != 0 : decel_out(); }
	// The K3701's net step pulse on axis k, and the command pulse its K3702 counts (after the
	// axis's accel/decel circuit in post placement).
	int steps(int k) const { return interp.out.step[k]; }
	int command(int k) const { return accel_post ? axis[k].post.out() : steps(k); }
	bool irq_alarm() const {
		for (int k = 0; k < axes; k++)
			if (axis[k].ctrl.irq)
				return true;
		return false;
	}
	// Whether every accel/decel circuit is quiet (Circuit::quiet).
	bool circuits_quiet() const {
		if (accel_pre && !accel.quiet())
			return false;
		for (int k = 0; k < axes; k++)
			if (accel_post && !axis[k].post.quiet())
				return false;
		return true;
	}
	bool quiet() const { return interp.quiet(fp()) && circuits_quiet(); }
	uint8_t r_data() const {
		switch (read_cs) {
		case SELECT_K3701: return interp.bank.r_data;
		case SELECT_K3702_X: return axis[0].ctrl.bank.r_data;
		case SELECT_K3702_Y: return axis[1].ctrl.bank.r_data;
		case SELECT_ENCODER_X: return axis[0].enc.bank.r_data;
		case SELECT_ENCODER_Y: return axis[1].enc.bank.r_data;
		case SELECT_FEED: return feed.bank.r_data;
		case SELECT_DECEL: return decel.bank.r_data;
		case SELECT_K3702_Z:  // and ENCODER_Z, told apart by A4
			return axes < 3 ? 0 : read_a4 ? axis[2].enc.bank.r_data : axis[2].ctrl.bank.r_data;
		default: return 0;
		}
	}

	// One chip's bank edge: its strobes where the address selects it (no aliases: the
	// address bits between the chip's map and the select are its window's).
	template<class Chip>
	BankEdge decode(const Chip &chip, unsigned select, unsigned window, unsigned width) const {
		bool hit = (addr >> REG_BITS) == select &&
		           (addr & low_bits(REG_BITS)) >> width == window >> width;
		return chip.bank.decode(w_stb && hit, r_stb && hit, unsigned(addr & low_bits(width)),
		                        uint8_t(w_data), [&](int reg) { return chip.read(reg); });
	}

	// A K3702 without a pulse or a strobe is at a fixed point: its falling edge is skipped.
	// The largest error magnitude is taken as the error changes (only here).
	void fall() {
		for (int k = 0; k < axes; k++) {
			Axis &a = axis[k];
			int com = command(k), fb = int(a.enc.fb_pos) - int(a.enc.fb_neg);
			if (com || fb || strobed) {
				uint64_t dac = a.ctrl.dac;
				a.ctrl.fall(com, fb);
				if (a.ctrl.dac != dac)  // the plant's input changes
					forget(k, dac);
				uint64_t magnitude = uint64_t(a.ctrl.error < 0 ? -a.ctrl.error : a.ctrl.error);
				a.max_abs_error = std::max(a.max_abs_error, magnitude);
			}
		}
	}

	void rise() {
		if (!(w_stb || r_stb || strobed)) {  // no bus cycle and no strobe to clear
			edge();
			return;
		}
		// The banks' edges, from the values before it.
		BankEdge e_feed = decode(feed, SELECT_FEED, WINDOW_FEED, FEED_ADDR_WIDTH);
		BankEdge e_decel = decode(decel, SELECT_DECEL, WINDOW_DECEL, DECEL_ADDR_WIDTH);
		BankEdge e_interp = decode(interp, SELECT_K3701, WINDOW_K3701,
		                           axes == 3 ? K3701_3_ADDR_WIDTH : K3701_ADDR_WIDTH);
		static constexpr unsigned CTRL_SELECTS[MAX_AXES][2] = {
		    {SELECT_K3702_X, WINDOW_K3702_X}, {SELECT_K3702_Y, WINDOW_K3702_Y},
		    {SELECT_K3702_Z, WINDOW_K3702_Z}};
		static constexpr unsigned ENC_SELECTS[MAX_AXES][2] = {
		    {SELECT_ENCODER_X, WINDOW_ENCODER_X}, {SELECT_ENCODER_Y, WINDOW_ENCODER_Y},
		    {SELECT_ENCODER_Z, WINDOW_ENCODER_Z}};
		BankEdge e_ctrl[MAX_AXES], e_enc[MAX_AXES];
		for (int k = 0; k < axes; k++) {
			e_ctrl[k] = decode(axis[k].ctrl, CTRL_SELECTS[k][0], CTRL_SELECTS[k][1],
			                   K3702_ADDR_WIDTH);
			e_enc[k] = decode(axis[k].enc, ENC_SELECTS[k][0], ENC_SELECTS[k][1],
			                  ENCODER_ADDR_WIDTH);
		}
		edge();
		if (r_stb) {
			read_cs = unsigned(addr >> REG_BITS) & 7;
			read_a4 = axes == 3 && bit(addr, REG_BITS - 1);
		}
		feed.bank.apply(e_feed);
		decel.bank.apply(e_decel);
		interp.bank.apply(e_interp);
		for (int k = 0; k < axes; k++) {
			axis[k].ctrl.bank.apply(e_ctrl[k]);
			axis[k].enc.bank.apply(e_enc[k]);
		}
		strobed = !banks_quiet();
	}
	// The chips' and plants' rising edge (the banks' aside). Each block's update reads only
	// its own state and its inputs of the values before the edge: the axes' blocks rise
	// before the chips whose outputs they take (the K3701's steps, the circuits' pulses).
	void edge() {
		for (int k = 0; k < axes; k++) {
			Axis &a = axis[k];
			a.enc.rise(a.plant.lines());
			if (!coast(k, command(k)))
				a.plant.rise(a.in, a.ctrl.dac, command(k));
			a.pulses_pos += steps(k) > 0;
			a.pulses_neg += steps(k) < 0;
		}
		rise_chips();
	}
	// The rising edge of the chips before the K3702s: the feed, the decel gate, the accel/decel
	// circuits and the K3701 (the feed's clocks read before it rises).
	void rise_chips() {
		bool gate = decel_out(), feed_pulse = fp();
		if (accel_post)
			for (int k = 0; k < axes; k++)
				axis[k].post.rise(steps(k), feed.clock(k).stb);
		if (accel_pre)
			accel.rise(gate, feed.fa_clock.stb);
		interp.rise(feed_pulse);
		feed.rise();
		decel.rise(gate);
		fp_total += feed_pulse;
	}

	void step() {
		pulse.known = carry.known = false;
		if (cycle)
			fall();
		rise();
		count_cycles(1);
	}

	// Count n cycles run or skipped, and take the sample that is due, if one is.
	void count_cycles(uint64_t n) {
		cycle += n;
		if (cycle == next_sample) {
			rows.push_back(cycle);
			for (int port : record_ports)
				rows.push_back(get(port));
			next_sample += every;
		}
	}

	// Whether the chips' next edge is theirs alone (the axes see no change of theirs): no bus
	// cycle, no bank strobe, no step pulse and the accel/decel circuits after the K3701 quiet.
	// With no count pulse and the axes settled, the cycles to come change nothing but the
	// free-running state, the plants and the encoder interfaces' filter streaks until an
	// event of theirs (horizon, or a filter passing a change).
	bool chips_alone() const {
		if (w_stb || r_stb || strobed)
			return false;
		for (int k = 0; k < axes; k++)
			if (steps(k) || (accel_post && !axis[k].post.quiet()))
				return false;
		return true;
	}
	// A count pulse of an encoder interface, for its K3702's next falling edge.
	bool pulsed() const {
		bool any = false;
		for (int k = 0; k < axes; k++)
			any |= axis[k].enc.fb_pos || axis[k].enc.fb_neg;
		return any;
	}
	// The encoder interfaces started, their lines complementary with no broken-line streak,
	// the plants' fault inputs as registered: with the chips quiet, the K3702s at a fixed
	// point. Once settled, the axes stay so while their inputs are held.
	bool axes_settled() const {
		for (int k = 0; k < axes; k++) {
			const Axis &a = axis[k];
			const Encoder &e = a.enc;
			const Drive &p = a.plant;
			if (!e.started || p.glitch_a != a.in.glitch_a || p.glitch_b != a.in.glitch_b ||
			    p.break_a != a.in.break_a)
				return false;
			Lines in = p.lines();
			if (in.a == in.a_n || in.b == in.b_n || e.line[0].broken || e.line[1].broken)
				return false;
		}
		return true;
	}
	bool banks_quiet() const {
		if (!feed.bank.quiet() || !decel.bank.quiet() || !interp.bank.quiet())
			return false;
		for (int k = 0; k < axes; k++)
			if (!axis[k].ctrl.bank.quiet() || !axis[k].enc.bank.quiet())
				return false;
		return true;
	}

	// The most cycles that can run before an event of the free-running state: a feed pulse
	// through the open decel gate, an accel/decel carry, the K3701's step or the end of its
	// setup (UINT64_MAX: none comes); 0 where the chips' next edge is itself an event.
	uint64_t horizon() {
		// The chips' next edge is an event: the circuit before the K3701 not quiet (an
		// output pulse pending, a linear stage draining), or the K3701 holding an FP.
		if (accel_pre && !accel.quiet()) {
			carry.known = false;
			return 0;
		}
		if (interp.phase == K3701::Phase::RUN && interp.count == 0 && interp.held)
			return 0;
		uint64_t h = UINT64_MAX;
		if (interp.phase == K3701::Phase::SETUP)
			h = uint64_t(interp.setup_left - 1);
		else if (interp.phase == K3701::Phase::RUN && interp.count)
			h = uint64_t(interp.count - 1);
		if (!pulse.known)
			pulse.set(cycle, pulse_free());
		h = std::min(h, pulse.left(cycle));
		if (accel_pre) {
			if (!carry.known)
				carry.set(cycle, carry_free(accel, feed.fa_clock, feed.bank.value[FEED_FA_INC]));
			h = std::min(h, carry.left(cycle));
		}
		if (accel_post)
			for (int k = 0; k < axes; k++)
				h = std::min(h, carry_free(axis[k].post, feed.clock(k), feed.increment(k)));
		return h;
	}
	// The cycles before a feed pulse passes the open decel gate.
	uint64_t pulse_free() const {
		if (!decel.gate_open())
			return UINT64_MAX;
		uint64_t clocks = clocks_before_pulse(feed.count, feed.bank.value[FEED_FEED], Feed::BITS);
		return clocks == UINT64_MAX ? UINT64_MAX
		                            : cycles_within(feed.rm_clock.phase, feed.bank.value[FEED_RM_INC],
		                                            feed.rm_clock.stb, DIVIDER_WIDTH, clocks);
	}
	// An event of the free-running state, kept as the cycle count at which its free cycles
	// end while what it depends on holds (the free-running state jumps exactly).
	struct Due {
		bool known = false;
		uint64_t at = 0;  // UINT64_MAX: none comes
		void set(uint64_t now, uint64_t free) {
			known = true;
			at = free >= UINT64_MAX - now ? UINT64_MAX : now + free;
		}
		uint64_t left(uint64_t now) const { return at == UINT64_MAX ? UINT64_MAX : at - now; }
		// After an event's cycle, which ended at cycle count `now`: whether this one came.
		bool came(uint64_t now) const { return at < now; }
	};
	// The feed pulse through the gate (kept until it comes or a whole-machine cycle) and the
	// carry of the circuit before the K3701 (until a feed pulse, its carry or a whole-machine
	// cycle).
	Due pulse, carry;
	// After the chips' event that ended at cycle count `now`: the events it changes forgotten.
	void renew(uint64_t now) {
		if (pulse.came(now))
			pulse.known = carry.known = false;
		if (carry.came(now))
			carry.known = false;
	}

	// The most cycles in which circuit c, on addition clock `clock`, takes no carry.
	static uint64_t carry_free(const Circuit &c, const Divider &clock, uint64_t increment) {
		uint64_t safe = c.safe_strobes();
		return safe == UINT64_MAX ? UINT64_MAX
		                          : cycles_within(clock.phase, increment, clock.stb, DIVIDER_WIDTH, safe);
	}

	// Advance the free-running state by k cycles (k >= 1; no event on the way).
	void advance_free(uint64_t k) {
		if (accel_pre)
			accel.advance(strobes_seen(feed.fa_clock, feed.bank.value[FEED_FA_INC], k));
		if (accel_post)
			for (int i = 0; i < axes; i++)
				axis[i].post.advance(strobes_seen(feed.clock(i), feed.increment(i), k));
		feed.count = (feed.count + strobes_seen(feed.rm_clock, feed.bank.value[FEED_RM_INC], k)) &
		             low_bits(Feed::BITS);
		advance(feed.rm_clock, feed.bank.value[FEED_RM_INC], k);
		advance(feed.fa_clock, feed.bank.value[FEED_FA_INC], k);
		for (int i = 0; i < 3; i++)
			if (feed.own[i] >= 0)
				advance(feed.fa_axis[i], feed.bank.value[feed.own[i]], k);
		if (interp.phase == K3701::Phase::SETUP)
			interp.setup_left -= int64_t(k);
		else if (interp.phase == K3701::Phase::RUN && interp.count)
			interp.count -= int64_t(k);
	}

	// A phase divider's strobes seen in the next k cycles, and its advance by k cycles (k >= 1).
	static uint64_t strobes_seen(const Divider &d, uint64_t increment, uint64_t k) {
		return k37e::strobes_seen(d.phase, increment, d.stb, DIVIDER_WIDTH, k);
	}
	static void advance(Divider &d, uint64_t increment, uint64_t k) {
		u128 before_last = u128(d.phase) + u128(k - 1) * increment, total = before_last + increment;
		d.stb = (total >> DIVIDER_WIDTH) != (before_last >> DIVIDER_WIDTH);
		d.phase = uint64_t(total) & low_bits(DIVIDER_WIDTH);
	}

	// Run up to n cycles, skipping where the machine is quiet, until `port` reads non-zero
	// (machine.cc).
	uint64_t run(uint64_t n, int port);

	// A port's value, and a port written (the port numbers of constants.h, the drives' after
	// every axis's); defined in machine.cc.
	uint64_t get(int port) const;
	void set(int port, uint64_t v);
};

}  // namespace k37e
