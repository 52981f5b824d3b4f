// The engine's machine: the two- or three-axis chipset (FEED, DECEL, an accel/decel circuit
// of any shape before the K3701, one per axis after it, or none; the K3701, a K3702 and an
// encoder interface per axis, the host bus decoding) with a servo drive per axis and
// the observation counters, composed as k37.sim.machine.system.System and
// k37.hdl.chipset.chip.Chipset wire them; its ports by the System's names; its cycles (a falling edge, except in the first, then a rising edge, as
// Amaranth's simulator clocks it); and its idle skipping: while nothing but the free-running
// state (the dividers, the rate multiplier's counter, the accel/decel accumulator, the K3701's
// latency or setup count), the plants and the encoder filters' streaks change, cycles are
// advanced in closed form up to the next event, the plants stepped alone, exactly as
// stepping the whole machine would; the chips' events that give the axes no command pulse
// and the K3702s' counts of encoder pulses are taken there alone (Machine::run).

#pragma once

#include <algorithm>
#include <cstring>
#include <utility>
#include <vector>

#include "blocks.h"
#include "drives.h"
#include "free.h"
#include "k3701.h"
#include "lag.h"

namespace k37e {

constexpr int MAX_AXES = 3;

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

struct Axis {
	Circuit post;  // the accel/decel circuit after the K3701 (post placement)
	K3702 ctrl;
	Encoder enc;
	Drive plant;
	PlantInputs in;
	uint64_t max_abs_error = 0;
	uint32_t pulses_pos = 0, pulses_neg = 0;
};

// Where the accel/decel circuit is (k37.hdl.chipset.map.Accel): before the K3701, one per
// axis after it, or none.
enum class Placement { NONE, PRE, POST };

struct Machine {
	const int axes;
	const Placement placement;
	const bool accel_pre, accel_post;
	Feed feed;
	Decel decel;
	Circuit accel;  // before the K3701 (pre placement)
	K3701 interp;
	Axis axis[MAX_AXES];
	uint64_t addr = 0, w_data = 0;
	bool w_stb = false, r_stb = false;
	unsigned read_cs = 0;
	bool read_a4 = false;  // select 7's window of the last read (three axes)
	bool strobed = false;  // a bank holds a strobe (committed or refused) of the last edge
	uint32_t fp_total = 0;
	uint64_t cycle = 0, skipped = 0;
	bool drives = false;  // an axis has a torque or two-mass drive (set_drive)
	// Samples of some ports at every multiple of `every` cycles (k37e_record): each row the
	// cycle and the ports' values; a skip's stretch ends at the next sample.
	std::vector<int> record_ports;
	uint64_t every = 0, next_sample = UINT64_MAX;
	std::vector<uint64_t> rows;

	// `shapes` and `bits`: the circuit before the K3701's, then each axis's (Circuit::Shape).
	// `fa_axes`: bit k set if axis k's circuit has an addition clock of its own.
	Machine(int chip_axes, Placement where, const int (&shapes)[1 + MAX_AXES],
	        const unsigned (&bits)[1 + MAX_AXES], unsigned fa_axes)
	    : axes(chip_axes), placement(where), accel_pre(where == Placement::PRE),
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
				a.ctrl.fall(com, fb);
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

	// Whether the cycles to come change nothing but the free-running state, the plants and
	// the encoder interfaces' filter streaks until an event of theirs (horizon, or a filter
	// passing a change): the chips quiet, no count pulse and the axes settled.
	bool quiet_now() const { return chips_quiet() && !pulsed() && axes_settled(); }
	// No bus cycle, no bank strobe, no step pulse or accel/decel output pulse, and the K3701
	// idle, counting down, or waiting for an FP it does not hold.
	bool chips_quiet() const {
		if (w_stb || r_stb || strobed)
			return false;
		for (int k = 0; k < axes; k++)
			if (steps(k))
				return false;
		if (interp.phase == K3701::Phase::RUN && interp.count == 0 && interp.held)
			return false;
		return circuits_quiet();
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
	// setup (UINT64_MAX: none comes).
	uint64_t horizon() const {
		uint64_t h = UINT64_MAX;
		if (interp.phase == K3701::Phase::SETUP)
			h = uint64_t(interp.setup_left - 1);
		else if (interp.phase == K3701::Phase::RUN && interp.count)
			h = uint64_t(interp.count - 1);
		if (decel.gate_open()) {
			uint64_t clocks = clocks_before_pulse(feed.count, feed.bank.value[FEED_FEED], Feed::BITS);
			if (clocks != UINT64_MAX)
				h = std::min(h, cycles_within(feed.rm_clock.phase, feed.bank.value[FEED_RM_INC],
				                              feed.rm_clock.stb, DIVIDER_WIDTH, clocks));
		}
		if (accel_pre)
			h = std::min(h, carry_free(accel, feed.fa_clock, feed.bank.value[FEED_FA_INC]));
		if (accel_post)
			for (int k = 0; k < axes; k++)
				h = std::min(h, carry_free(axis[k].post, feed.clock(k), feed.increment(k)));
		return h;
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

	// Step the plants and the encoder interfaces alone for at most h cycles (the plants' D/A
	// words and inputs held, no command pulse), up to and including the first cycle in which
	// an encoder interface's filter passes a change; the cycles run. The plants in pieces,
	// exactly (lag.h, as the compiled RTL backend's skips step them), each ending at a count
	// change; over each piece the encoders see the lines it started with, their filter
	// streaks advanced in closed form (Encoder::advance); the cycle in which a filter passes a
	// change runs the encoders' whole edge (its count pulse ends the stretch).
	uint64_t advance_plants(uint64_t h) {
		uint64_t done = 0;
		while (done < h) {
			uint64_t piece = h - done;
			Lines in[MAX_AXES];
			for (int i = 0; i < axes; i++) {
				in[i] = axis[i].plant.lines();
				piece = std::min(piece, axis[i].enc.steady_cycles(in[i]));
			}
			if (piece == 0) {
				for (int i = 0; i < axes; i++)
					axis[i].enc.rise(in[i]);
				return done + run_plants(1);
			}
			uint64_t k = run_plants(piece);
			for (int i = 0; i < axes; i++)
				axis[i].enc.advance(in[i], k);
			done += k;
		}
		return done;
	}
	// Run the plants alone for at most n cycles, up to and including the first cycle that
	// changes a count; the cycles run. The torque and two-mass drives stepped; first-order
	// plants with an update period held between updates (lag.h, advance_held); else stepped
	// cycle by cycle, or in pieces in closed form (lag.h, advance).
	uint64_t run_plants(uint64_t n) {
		if (drives)
			return advance_drives(n);
		for (int i = 0; i < axes; i++)
			if (!axis[i].plant.every_cycle(axis[i].in))
				return hold_plants(n);
		return n <= STEPPED_PIECE ? step_plants(n) : lag_plants(n);
	}
	// Pieces of at most this many cycles are stepped cycle by cycle (Plant::rise): cheaper
	// than the closed forms' set-up over a few cycles, and the same update.
	static constexpr uint64_t STEPPED_PIECE = 16;
	// run_plants of plants updated every cycle, cycle by cycle.
	uint64_t step_plants(uint64_t n) { return axes == 3 ? step_plants<3>(n) : step_plants<2>(n); }
	template<int N>
	uint64_t step_plants(uint64_t n) {
		Plant p[N];
		int64_t vc[N];
		for (int i = 0; i < N; i++) {
			p[i] = axis[i].plant;
			vc[i] = Plant::command(axis[i].in, axis[i].ctrl.dac, 0);
		}
		uint64_t j = 0;
		for (bool crossed = false; j < n && !crossed;) {
			j++;
			for (int i = 0; i < N; i++) {
				uint64_t before = p[i].before + uint64_t(p[i].velocity);
				p[i].before = before;
				p[i].velocity = p[i].next_velocity(axis[i].in, vc[i]);
				crossed |= (before ^ (before + uint64_t(p[i].velocity))) >> FRAC_BITS != 0;
			}
		}
		for (int i = 0; i < N; i++)
			static_cast<Plant &>(axis[i].plant) = p[i];
		return j;
	}
	uint64_t lag_plants(uint64_t n) {
		k37lag::Lag lags[MAX_AXES] = {lag(axis[0]), lag(axis[1]), lag(axis[2])};
		int64_t steps[MAX_AXES];
		bool crossed;
		uint64_t k = k37lag::advance(lags, size_t(axes), steps, n, crossed);
		for (int i = 0; i < axes; i++)
			take(axis[i].plant, lags[i]);
		return k;
	}
	// A plant's registers from the state lag.h advanced it to.
	static void take(Plant &p, const k37lag::Lag &lag) {
		p.velocity = lag.v;
		p.before = lag.position - uint64_t(lag.v);
		p.phase = lag.phase;
		if (!lag.pending)
			p.ff = 0;
	}
	// run_plants of first-order plants with an update period.
	uint64_t hold_plants(uint64_t n) { return axes == 3 ? hold_plants<3>(n) : hold_plants<2>(n); }
	template<int N>
	uint64_t hold_plants(uint64_t n) {
		k37lag::Lag lags[N];
		for (int i = 0; i < N; i++) {
			const Axis &a = axis[i];
			lags[i] = lag(a);
			int64_t next = a.plant.ff ? Plant::command(a.in, a.ctrl.dac, a.plant.ff) : lags[i].vc;
			lags[i].hold(a.in.period, a.plant.phase, next);
		}
		bool crossed;
		uint64_t k = k37lag::advance_held(lags, size_t(N), n, crossed);
		for (int i = 0; i < N; i++)
			take(axis[i].plant, lags[i]);
		return k;
	}
	// run_plants with a torque or two-mass drive (drives.h).
	uint64_t advance_drives(uint64_t h) {
		Drive *plants[MAX_AXES];
		const PlantInputs *ins[MAX_AXES];
		uint64_t dacs[MAX_AXES];
		for (int i = 0; i < axes; i++) {
			plants[i] = &axis[i].plant;
			ins[i] = &axis[i].in;
			dacs[i] = axis[i].ctrl.dac;
		}
		return k37e::advance_drives(plants, ins, dacs, axes, h);
	}
	static k37lag::Lag lag(const Axis &a) {
		const Plant &p = a.plant;
		return k37lag::Lag(p.velocity, Plant::command(a.in, a.ctrl.dac, 0), int64_t(a.in.alpha),
		                   p.before + uint64_t(p.velocity), a.in.stall, VC_BITS, ALPHA_BITS,
		                   FRAC_BITS);
	}

	// Run up to n cycles, skipping where the machine is quiet, until `port` reads non-zero
	// (machine.cc).
	uint64_t run(uint64_t n, int port);

	// Axis k's drive (a DriveKind).
	void set_drive(int k, int kind) {
		axis[k].plant.kind = DriveKind(kind);
		drives |= kind != int(DriveKind::FIRST_ORDER);
	}

	// A port's value, and a port written (the port numbers of constants.h, the drives' after
	// every axis's); defined in machine.cc.
	uint64_t get(int port) const;
	void set(int port, uint64_t v);
};

}  // namespace k37e
