// The engine's blocks, one struct per chip of the chipset and per plant: the state the
// gateware registers hold and its updates, stated after each block's reference model and
// gateware (hdl/**/model*.py, sim/machine/plant_model.py). Each `rise` is the block's rising
// edge, computed from the values before the edge (what its caller passes in); the K3702's
// counters change at the falling edge (`fall`). Register banks (Bank) time the host bus as
// k37.hdl.bus.hostbus.RegisterBank does. Constants come from constants.h (generated).

#pragma once

#include <algorithm>
#include <cstdint>

#include "constants.h"

namespace k37e {

inline uint64_t low_bits(unsigned bits) { return bits >= 64 ? ~uint64_t(0) : (uint64_t(1) << bits) - 1; }
inline int64_t sext(uint64_t v, unsigned bits) {
	return bits >= 64 ? int64_t(v) : int64_t(v << (64 - bits)) >> (64 - bits);
}
inline int64_t wrap(int64_t v, unsigned bits) { return sext(uint64_t(v), bits); }
inline bool bit(uint64_t v, unsigned b) { return v >> b & 1; }

constexpr int MAX_REGS = 16;

// A register bank's edge, decided from the values before it (Bank::decode), applied after the
// chip's own update (Bank::apply).
struct BankEdge {
	int reg = -1;         // the register addressed (-1: none)
	bool write = false, read = false;
	unsigned byte = 0;
	uint8_t w_data = 0;
	uint64_t read_value = 0;  // the chip's r_data of the register, for a read of byte 0
};

// k37.hdl.bus.hostbus.RegisterBank: shadows, latches, committed values and the strobes.
struct Bank {
	const RegSpec *regs = nullptr;
	int count = 0;
	uint64_t value[MAX_REGS] = {}, shadow[MAX_REGS] = {}, latch[MAX_REGS] = {};
	int committed = -1, refused = -1;  // the register committed (refused) at the last edge
	uint8_t r_data = 0;

	void init(const RegSpec *specs, int n) {
		regs = specs;
		count = n;
		for (int i = 0; i < n; i++)
			value[i] = specs[i].init & low_bits(8 * specs[i].nbytes);
	}
	bool stb(int reg) const { return committed == reg; }
	// No strobe: no register committed or refused at the last edge.
	bool quiet() const { return committed < 0 && refused < 0; }
	bool err(int reg) const { return refused == reg; }
	int64_t get(int reg) const {
		return regs[reg].is_signed ? sext(value[reg], 8 * regs[reg].nbytes) : int64_t(value[reg]);
	}
	// `read(reg)` is the chip's r_data of a register, taken only for a read of its byte 0.
	template<class Read>
	BankEdge decode(bool w_stb, bool r_stb, unsigned addr, uint8_t w_data, Read read) const {
		BankEdge e;
		if (!(w_stb || r_stb))
			return e;
		e.write = w_stb;
		e.read = r_stb;
		e.w_data = w_data;
		for (int i = 0; i < count; i++)
			if (addr >= regs[i].addr && addr < regs[i].addr + regs[i].nbytes) {
				e.reg = i;
				e.byte = addr - regs[i].addr;
				if (r_stb && regs[i].readable && e.byte == 0)
					e.read_value = read(i);
				break;
			}
		return e;
	}
	void apply(const BankEdge &e) {
		committed = refused = -1;
		if (!(e.write || e.read))
			return;
		if (e.reg < 0) {
			if (e.read)
				r_data = 0;
			return;
		}
		const RegSpec &r = regs[e.reg];
		unsigned last = r.nbytes - 1;
		if (r.writable && e.write) {
			if (e.byte < last) {
				shadow[e.reg] = (shadow[e.reg] & ~(uint64_t(0xff) << 8 * e.byte)) |
				                uint64_t(e.w_data) << 8 * e.byte;
			} else {
				uint64_t word = (shadow[e.reg] & low_bits(8 * last)) | uint64_t(e.w_data) << 8 * last;
				int64_t v = r.is_signed ? sext(word, 8 * r.nbytes) : int64_t(word);
				if (!r.checked || (v >= r.lo && v <= r.hi)) {
					value[e.reg] = word;
					committed = e.reg;
				} else {
					refused = e.reg;
				}
			}
		}
		if (e.read) {
			if (!r.readable)
				r_data = 0;
			else if (e.byte == 0) {
				r_data = uint8_t(e.read_value);
				latch[e.reg] = e.read_value >> 8;
			} else {
				r_data = uint8_t(latch[e.reg] >> 8 * (e.byte - 1));
			}
		}
	}
};

// k37.hdl.feed.divider.PhaseDivider: the strobe is registered, a cycle after its carry.
struct Divider {
	uint64_t phase = 0;
	bool stb = false;
	void rise(uint64_t increment) {
		uint64_t total = phase + increment;
		stb = total >> DIVIDER_WIDTH & 1;
		phase = total & low_bits(DIVIDER_WIDTH);
	}
};

// k37.hdl.feed.feed_rate.FeedRate: the rate multiplier's clock divider, its counter, the
// addition clock fa and, in the per-axis fa build, an axis's own (`own[k]`: the bank's index
// of axis k's increment register FA_INC_X, ..., or -1 for the shared fa).
struct Feed {
	Bank bank;
	RegSpec specs[FEED_FA_REG_COUNT];  // the build's registers: the plain map's, then the axes'
	Divider rm_clock, fa_clock, fa_axis[3];
	int own[3] = {-1, -1, -1};
	uint64_t count = 0;  // the rate multiplier's counter
	static constexpr unsigned BITS = STAGE_BITS * FEED_STAGES;

	// The build with its own addition clock for each axis k whose bit k of `axes` is set.
	void init(unsigned axes) {
		int n = 0;
		for (; n < FEED_REG_COUNT; n++)
			specs[n] = FEED_FA_REGS[n];
		for (int k = 0; k < 3; k++)
			if (axes >> k & 1) {
				own[k] = n;
				specs[n++] = FEED_FA_REGS[FEED_FA_FA_INC_X + k];
			}
		bank.init(specs, n);
	}
	// Axis k's addition clock (the shared fa for k < 0) and its increment.
	const Divider &clock(int k) const { return k >= 0 && own[k] >= 0 ? fa_axis[k] : fa_clock; }
	uint64_t increment(int k) const {
		return bank.value[k >= 0 && own[k] >= 0 ? own[k] : FEED_FA_INC];
	}

	// The rate multiplier's output: the clock gated by the word bit that the counter's next
	// state selects (its trailing ones, k37.hdl.feed.model.rate_multiplier.selected_bit).
	bool out() const {
		if (!rm_clock.stb)
			return false;
		uint64_t next = (count + 1) & low_bits(BITS);
		unsigned ones = __builtin_ctzll(~next);
		return ones < BITS && bit(bank.value[FEED_FEED], BITS - 1 - ones);
	}
	void rise() {
		if (rm_clock.stb)
			count = (count + 1) & low_bits(BITS);
		rm_clock.rise(bank.value[FEED_RM_INC]);
		fa_clock.rise(bank.value[FEED_FA_INC]);
		for (int k = 0; k < 3; k++)
			if (own[k] >= 0)
				fa_axis[k].rise(bank.value[own[k]]);
	}
	uint64_t read(int reg) const { return bank.value[reg]; }
};

// k37.hdl.feed.decel_control.DecelControl: the FP budget gate.
struct Decel {
	Bank bank;
	uint64_t remaining = 0;

	bool hold() const { return bit(bank.value[DECEL_CTRL], DECEL_CTRL_HOLD); }
	uint64_t current() const { return bank.stb(DECEL_BUDGET) ? bank.value[DECEL_BUDGET] : remaining; }
	bool gate_open() const { return !hold() && current() != 0; }
	void rise(bool out) { remaining = (current() - out) & low_bits(BUDGET_WIDTH); }
	uint64_t read(int reg) const {
		bool spent = remaining == 0;
		switch (reg) {
		case DECEL_REMAINING: return remaining;
		case DECEL_CTRL: return bank.value[DECEL_CTRL];
		case DECEL_STATUS:
			return uint64_t(spent) << DECEL_STATUS_SPENT | uint64_t(!spent && !hold()) << DECEL_STATUS_OPEN;
		default: return 0;
		}
	}
};

// k37.hdl.accel.exponential.AccelDecel: one direction before the interpolator, or
// bidirectional after it (x and pending signed, net pulses +1, 0, -1).
struct Accel {
	unsigned n = 15;
	bool bidirectional = false;
	int64_t x = 0, pending = 0;
	uint64_t y = 0;

	// The output pulse of this cycle (net: out_pos - out_neg).
	int out() const { return bidirectional ? (pending > 0) - (pending < 0) : pending != 0; }
	int64_t counter(int64_t v) const {
		return bidirectional ? wrap(v, ACCEL_COUNTER_WIDTH) : int64_t(uint64_t(v) & low_bits(ACCEL_COUNTER_WIDTH));
	}
	// The carry of the addition y + x at an fa strobe (a floor: a borrow when x < 0).
	int64_t carry() const { return (int64_t(y) + x) >> n; }
	void rise(int inp, bool add) {
		int64_t c = add ? carry() : 0;
		if (add)
			y = uint64_t(int64_t(y) + x) & low_bits(n);
		int o = out();
		x = counter(x - c + inp);
		pending = counter(pending - o + c);
	}
	// Strobes of its addition clock that may come without a carry (UINT64_MAX: any number).
	uint64_t safe_strobes() const {
		if (x == 0)
			return UINT64_MAX;
		return x > 0 ? (low_bits(n) - y) / uint64_t(x) : y / uint64_t(-x);
	}
};

// k37.hdl.accel.linear.AccelLinear: the moving average over 2^n additions, a window of
// 2^BINS_BITS bins (a ring, oldest at `head`), one direction or bidirectional.
struct LinearAccel {
	unsigned n = 15;
	bool bidirectional = false;
	int64_t x = 0, pending = 0, open = 0, bins[1 << LINEAR_BINS_BITS] = {};
	uint64_t y = 0, tick = 0;
	int live = 0, head = 0;
	static constexpr int COUNT = 1 << LINEAR_BINS_BITS;

	bool active() const { return open != 0 || live != 0; }
	bool idle() const { return !active() && pending == 0; }
	int out() const { return bidirectional ? (pending > 0) - (pending < 0) : pending != 0; }
	int64_t counter(int64_t v) const {
		return bidirectional ? wrap(v, ACCEL_COUNTER_WIDTH) : int64_t(uint64_t(v) & low_bits(ACCEL_COUNTER_WIDTH));
	}
	void rise(int inp, bool add) {
		int o = out();
		int64_t carry = 0;
		if (add) {
			int64_t total = int64_t(y) + x;
			carry = total >> n;
			y = uint64_t(total) & low_bits(n);
			if (active()) {
				if (tick == low_bits(n - LINEAR_BINS_BITS)) {
					int64_t oldest = bins[head];
					bins[head] = open;
					head = (head + 1) % COUNT;
					x = counter(x + open - oldest);
					live = open != 0 ? COUNT : live - 1;
					open = 0;
					tick = 0;
				} else {
					tick++;
				}
			}
		}
		open = counter(open + inp);
		pending = counter(pending - o + carry);
	}
};

// An accel/decel circuit of any shape (k37.hdl.chipset.map.AccelShape): the exponential, the
// linear, or the bell (the linear one into the exponential one, on one addition clock).
struct Circuit {
	enum class Shape { EXPONENTIAL, LINEAR, BELL } shape = Shape::EXPONENTIAL;
	Accel exp;
	LinearAccel lin;

	void init(int code, unsigned n, bool bidirectional) {
		shape = Shape(code);
		exp.n = lin.n = n;
		exp.bidirectional = lin.bidirectional = bidirectional;
	}
	int out() const { return shape == Shape::LINEAR ? lin.out() : exp.out(); }
	// The circuit's `idle`: every stage drained (k37.hdl.accel's idle outputs).
	bool idle() const {
		bool exp_idle = shape == Shape::LINEAR || (exp.x == 0 && exp.pending == 0);
		return exp_idle && (shape == Shape::EXPONENTIAL || lin.idle());
	}
	// The circuit's `quiet`: no output pulse pending, a linear stage drained (then static).
	bool quiet() const {
		bool drained = shape == Shape::EXPONENTIAL || lin.idle();
		return drained && (shape == Shape::LINEAR || exp.pending == 0);
	}
	void rise(int inp, bool add) {
		if (shape == Shape::LINEAR) {
			lin.rise(inp, add);
			return;
		}
		int into = shape == Shape::BELL ? lin.out() : inp;
		exp.rise(into, add);
		if (shape == Shape::BELL)
			lin.rise(inp, add);
	}
	// While quiet: the strobes of its addition clock that come without a carry, and the
	// accumulator's advance by `strobes` of them (a drained linear stage is static).
	uint64_t safe_strobes() const { return shape == Shape::LINEAR ? UINT64_MAX : exp.safe_strobes(); }
	void advance(uint64_t strobes) {
		if (shape != Shape::LINEAR)
			exp.y = (exp.y + strobes * uint64_t(exp.x)) & low_bits(exp.n);
	}
};

// One line of k37.hdl.encoder.chip.EncoderInterface: receiver, line-fault streak, filter.
struct EncoderLine {
	bool held = false, level = false, fault = false;
	unsigned broken = 0, run = 0;  // the two streaks' counts
};

// The quadrature lines an encoder interface samples.
struct Lines {
	bool a, a_n, b, b_n;
};

// k37.hdl.encoder.chip.EncoderInterface.
struct Encoder {
	Bank bank;
	EncoderLine line[2];
	bool started = false, fb_pos = false, fb_neg = false, quad_error = false, bad_config = false;

	static bool streak(bool cond, unsigned &count, unsigned k) {
		bool done = cond && count + 1 >= k;
		count = cond && !done ? (count + 1) & 0xff : 0;
		return done;
	}
	void rise(const Lines &in) {
		// A cycle of steady complementary lines without a bank strobe, that passes no change:
		// the closed form's one cycle (no count pulse, flag or fault changes).
		if (started && bank.quiet() && in.a != in.a_n && in.b != in.b_n && steady_cycles(in)) {
			advance(in, 1);
			line[0].broken = line[1].broken = 0;
			fb_pos = fb_neg = false;
			return;
		}
		unsigned k = unsigned(bank.value[ENCODER_FILTER]);
		bool clear = bank.stb(ENCODER_CMD) && bit(bank.value[ENCODER_CMD], ENCODER_CMD_CLEAR);
		bool change[2], now[2];
		const bool pins[2][2] = {{in.a, in.a_n}, {in.b, in.b_n}};
		for (int i = 0; i < 2; i++) {
			EncoderLine &l = line[i];
			bool complementary = pins[i][0] != pins[i][1];
			bool received = complementary ? pins[i][0] : l.held;
			bool broken = streak(!complementary, l.broken, k);
			change[i] = streak(started && received != l.level, l.run, k);
			now[i] = change[i] || !started ? received : l.level;
			l.held = received;
			l.fault = (l.fault && !clear) || broken;
			l.level = now[i];
		}
		bool up = change[0] ? now[0] != now[1] : now[0] == now[1];
		unsigned decode = bank.value[ENCODER_MODE] >> ENCODER_MODE_DECODE & low_bits(ENCODER_MODE_DECODE_WIDTH);
		bool count = decode == 2 ? change[0] != change[1]
		                         : change[0] && !change[1] && (decode == 1 || !now[1]);
		fb_pos = count && up;
		fb_neg = count && !up;
		quad_error = (quad_error && !clear) || (change[0] && change[1]);
		bad_config = (bad_config && !clear) || bank.err(ENCODER_FILTER) || bank.err(ENCODER_MODE);
		started = true;
	}
	// While the lines `in` stay as they are (complementary, no bank strobe, started): the
	// cycles that change no filtered level (each line's filter streak runs on towards its
	// length or stays reset; UINT64_MAX: any number), and those cycles' advance (j >= 1; no
	// count pulse, no fault on the way).
	uint64_t steady_cycles(const Lines &in) const {
		uint64_t k = bank.value[ENCODER_FILTER], cycles = UINT64_MAX;
		for (int i = 0; i < 2; i++) {
			const EncoderLine &l = line[i];
			if ((i ? in.b : in.a) != l.level)
				cycles = std::min(cycles, l.run + 1 < k ? k - 1 - l.run : 0);
		}
		return cycles;
	}
	// Whether the lines `in` (complementary, no bank strobe, started) leave the interface as
	// it is: each at its filtered level, as received last, with no streak.
	bool rests(const Lines &in) const {
		return in.a == line[0].level && in.b == line[1].level && line[0].held == in.a &&
		       line[1].held == in.b && !line[0].run && !line[1].run;
	}
	void advance(const Lines &in, uint64_t j) {
		for (int i = 0; i < 2; i++) {
			EncoderLine &l = line[i];
			bool pin = i ? in.b : in.a;
			l.held = pin;
			l.run = pin != l.level ? unsigned(l.run + j) : 0;
		}
	}
	uint64_t read(int reg) const {
		if (reg == ENCODER_STATUS)
			return uint64_t(line[0].fault) << ENCODER_STATUS_LINE_FAULT_A |
			       uint64_t(line[1].fault) << ENCODER_STATUS_LINE_FAULT_B |
			       uint64_t(quad_error) << ENCODER_STATUS_QUAD_ERROR |
			       uint64_t(bad_config) << ENCODER_STATUS_BAD_CONFIG |
			       uint64_t(line[0].level) << ENCODER_STATUS_A | uint64_t(line[1].level) << ENCODER_STATUS_B;
		return bank.value[reg];
	}
};

// k37.hdl.k3702.chip.K3702: counters and flags at the falling edge.
struct K3702 {
	Bank bank;
	int64_t command = 0, error = 0;
	uint64_t dac = uint64_t(1) << (K3702_REGS[K3702_DAC_BITS].init - 1);
	bool sat_pos = false, sat_neg = false, in_position = true, negative = false, alarm_n = true,
	     irq = false, bad_config = false;

	bool cmd(unsigned field) const { return bank.stb(K3702_CMD) && bit(bank.value[K3702_CMD], field); }
	void fall(int com, int fb) {
		int64_t correct = bank.stb(K3702_CORRECT) ? bank.get(K3702_CORRECT) : 0;
		int64_t delta = com + correct;
		int64_t base_command = bank.stb(K3702_COMMAND) ? bank.get(K3702_COMMAND)
		                       : cmd(K3702_CMD_CLEAR_COMMAND) ? 0 : command;
		int64_t base_error = bank.stb(K3702_ERROR) ? bank.get(K3702_ERROR)
		                     : cmd(K3702_CMD_CLEAR_ERROR) ? 0 : error;
		int64_t e = wrap(base_error + delta - fb, COUNTER_WIDTH);
		uint64_t magnitude = uint64_t(e < 0 ? -e : e);
		int64_t half = int64_t(1) << (bank.value[K3702_DAC_BITS] - 1);
		bool alarm = magnitude > bank.value[K3702_ALARM_ZONE];
		bool ack = cmd(K3702_CMD_ACK), clear = cmd(K3702_CMD_CLEAR);
		command = wrap(base_command + delta, COUNTER_WIDTH);
		error = e;
		sat_pos = e >= half;
		sat_neg = e < -half;
		dac = uint64_t(sat_pos ? 2 * half - 1 : sat_neg ? 0 : e + half) & 0xffff;
		in_position = magnitude <= bank.value[K3702_POSITION_ZONE];
		negative = e < 0;
		irq = (irq && !ack) || (alarm && alarm_n);
		alarm_n = !alarm;
		bad_config = (bad_config && !clear) || bank.err(K3702_DAC_BITS);
	}
	uint64_t read(int reg) const {
		switch (reg) {
		case K3702_COMMAND: return uint64_t(command) & low_bits(COUNTER_WIDTH);
		case K3702_ERROR: return uint64_t(error) & low_bits(COUNTER_WIDTH);
		case K3702_STATUS:
			return uint64_t(in_position) << K3702_STATUS_IN_POSITION |
			       uint64_t(negative) << K3702_STATUS_NEGATIVE | uint64_t(sat_pos) << K3702_STATUS_SAT_POS |
			       uint64_t(sat_neg) << K3702_STATUS_SAT_NEG | uint64_t(!alarm_n) << K3702_STATUS_ALARM |
			       uint64_t(irq) << K3702_STATUS_IRQ | uint64_t(bad_config) << K3702_STATUS_BAD_CONFIG;
		default: return bank.value[reg];
		}
	}
};

}  // namespace k37e
