// The first-order servo plant's velocity lag and position (sim/machine/plant.py; its model:
// sim/machine/plant_model.py, ServoPlantModel), advanced exactly over the cycles in which no
// encoder count changes: in closed form while the velocity is steady, piece by piece while it
// ramps (a constant rounded step, the position a quadratic in the cycles), one cycle at a time
// where it lands. Shared by the compiled RTL harness's skips (plant.cc) and the engine's
// (sim/backends/engine/machine.h); self-contained, so that either can include it.

#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace k37lag {

using i128 = __int128;

// a / b truncated, as C++ divides (b != 0): in 64 bits where both fit (the common case; a
// 128-bit division is a library call).
inline i128 quotient(i128 a, i128 b) {
	if (a == int64_t(a) && b == int64_t(b) && !(int64_t(a) == INT64_MIN && b == -1))
		return int64_t(a) / int64_t(b);
	return a / b;
}

// a / b rounded up (b > 0).
inline i128 ceil_div(i128 a, i128 b) {
	i128 q = quotient(a, b);
	return q + (a - q * b > 0 ? 1 : 0);
}

// One plant's state and (constant) inputs, and its update, as the gateware
// (sim/machine/plant.py) and its model (sim/machine/plant_model.py, ServoPlantModel.cycle)
// compute them: the position (before + v, what the count is taken from) and the velocity.
struct Lag {
	int64_t v, vc, alpha;
	uint64_t position, low;  // low: the first position of the current count
	bool stall;
	unsigned vc_bits, alpha_bits, frac_bits;

	// With an update period (held): the cycles from one update to the next, the cycles
	// since the last (0: this cycle updates), and the command of the next update (vc with
	// the feedforward summed before it; vc itself from then on).
	uint64_t period = 1, phase = 0;
	int64_t vc_next;
	bool pending = false;  // the summed feedforward is not yet taken by an update

	Lag() = default;
	Lag(int64_t velocity, int64_t command, int64_t alpha_, uint64_t position_, bool stall_,
	    unsigned vc_bits_, unsigned alpha_bits_, unsigned frac_bits_)
	    : v(velocity), vc(command), alpha(alpha_), position(position_),
	      low(position_ >> frac_bits_ << frac_bits_), stall(stall_), vc_bits(vc_bits_),
	      alpha_bits(alpha_bits_), frac_bits(frac_bits_), vc_next(command) {}
	// The velocity after the next update (in range: |vc|, |v| <= 2^vc_bits - 1).
	int64_t next_v() const { return next_v(vc); }
	int64_t next_v(int64_t command) const {
		uint64_t delta =
		    uint64_t(command - v) * uint64_t(alpha) + (uint64_t(1) << (alpha_bits - 1));
		int64_t step = int64_t(delta) >> alpha_bits;
		return stall ? 0 : step == 0 ? command : v + step;
	}
	// An update period of `every` cycles (0 or 1: every cycle), `since` cycles since the
	// last update, and the next update's command `next`.
	void hold(uint64_t every, uint64_t since, int64_t next) {
		period = every < 1 ? 1 : every;
		phase = since;
		vc_next = next;
		pending = true;
	}
	// Whether the plant updates every cycle towards vc (advance's closed forms apply).
	bool every_cycle() const { return period == 1 && phase == 0 && vc_next == vc; }
	// Held: the cycles before the next update (0: this cycle updates).
	uint64_t until_update() const { return phase == 0 ? 0 : period - phase; }
	// Held: whether the updates to come change nothing (v at its command, nothing summed).
	bool settled() const { return steady() && vc_next == vc; }
	// Held: one cycle (the update, if it is due; the position).
	void cycle() {
		if (phase == 0) {
			v = next_v(vc_next);
			vc_next = vc;
			pending = false;
		}
		phase = phase + 1 >= period ? 0 : phase + 1;
		position += uint64_t(v);
	}
	// Held: k cycles with no update, at velocity v.
	void coast(uint64_t k) {
		position += uint64_t(v) * k;
		phase += k;
		if (phase >= period)  // most often one period on: no division
			phase = phase - period < period ? phase - period : phase % period;
	}
	// At a steady velocity: how many of `run` cycles keep the count (all, found without a
	// division where they do).
	uint64_t keeps(uint64_t run) const {
		if (offset_keeps(i128(position - low) + i128(v) * i128(run)))
			return run;
		return std::min(run, steady_cycles());
	}
	// Whether the position has left the count it started in.
	bool left_count() const { return (position - low) >> frac_bits != 0; }
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
	// How many cycles surely keep the count: the velocity moves from v towards its target
	// and lands there without overshoot (alpha < 2^alpha_bits), so the position moves no
	// faster than the larger of the two (UINT64_MAX: both are 0).
	uint64_t clear() const {
		int64_t target = stall ? 0 : vc, up = std::max(v, target), down = std::min(v, target);
		uint64_t offset = position - low, top = (uint64_t(1) << frac_bits) - 1, c = UINT64_MAX;
		if (up > 0)
			c = (top - offset) / uint64_t(up);
		if (down < 0)
			c = std::min(c, offset / uint64_t(-down));
		return c;
	}
	// k cycles known to keep the count (advance's pieces, without looking for a change).
	void run(uint64_t k) {
		while (k) {
			if (steady()) {
				position += uint64_t(v) * k;
				return;
			}
			int64_t s = ramp_step();
			if (s == 0) {  // the update lands the velocity
				take(next_v());
				k--;
				continue;
			}
			uint64_t j = std::min(k, ramp_cycles(s));
			take_ramp(s, j);
			k -= j;
		}
	}
};

// Step `n` plants for up to `limit` cycles, up to and including the first cycle that changes
// a count (then `crossed`); returns the cycles stepped. `steps` is scratch space for n values.
inline uint64_t advance(Lag *states, size_t n, int64_t *steps, uint64_t limit, bool &crossed) {
	crossed = false;
	uint64_t k = 0;
	while (k < limit) {
		if (std::all_of(states, states + n, [](const Lag &s) { return s.steady(); })) {
			uint64_t run = limit - k;
			for (size_t i = 0; i < n; i++)
				run = std::min(run, states[i].steady_cycles());
			for (size_t i = 0; i < n; i++)
				states[i].position += uint64_t(states[i].v) * run;
			k += run;
			break;
		}
		// The longest piece over which each plant's update is the same kind: a ramp step of
		// constant s, or (steady) none; a landing update is a piece of one cycle.
		uint64_t run = limit - k;
		bool landing = false;
		for (size_t i = 0; i < n; i++) {
			const Lag &s = states[i];
			steps[i] = s.steady() ? 0 : s.ramp_step();
			if (!s.steady() && steps[i] == 0)
				landing = true;
			else if (steps[i] != 0)
				run = std::min(run, s.ramp_cycles(steps[i]));
		}
		if (landing) {
			bool keeps = true;
			for (size_t i = 0; i < n; i++) {
				steps[i] = states[i].next_v();
				keeps &= states[i].keeps_count(steps[i]);
			}
			if (!keeps)
				break;
			for (size_t i = 0; i < n; i++)
				states[i].take(steps[i]);
			k++;
			continue;
		}
		uint64_t keep = run;
		for (size_t i = 0; i < n; i++)
			keep = std::min(keep, steps[i] != 0 ? states[i].ramp_keeps(steps[i], run)
			                                     : std::min(run, states[i].steady_cycles()));
		for (size_t i = 0; i < n; i++) {
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
		for (size_t i = 0; i < n; i++)
			states[i].take(states[i].next_v());
		k++;
		crossed = true;
	}
	return k;
}

// advance for plants with an update period (Lag::hold): the velocities held between updates,
// the cycles between them jumped in closed form, up to and including the first cycle that
// changes a count (then `crossed`); returns the cycles run.
inline __attribute__((always_inline)) uint64_t advance_held(Lag *states, size_t n,
                                                             uint64_t limit, bool &crossed) {
	crossed = false;
	uint64_t k = 0;
	while (k < limit) {
		uint64_t run = limit - k;  // cycles with no update that changes a velocity
		for (size_t i = 0; i < n; i++)
			if (!states[i].settled())
				run = std::min(run, states[i].until_update());
		if (run == 0) {  // an update is due: one cycle
			for (size_t i = 0; i < n; i++) {
				states[i].cycle();
				crossed |= states[i].left_count();
			}
			k++;
			if (crossed)
				return k;
			continue;
		}
		uint64_t keep = run;
		for (size_t i = 0; i < n; i++)
			keep = states[i].keeps(keep);
		for (size_t i = 0; i < n; i++)
			states[i].coast(keep);
		k += keep;
		if (keep < run) {  // the next cycle changes a count: run it, the last
			for (size_t i = 0; i < n; i++)
				states[i].cycle();
			crossed = true;
			return k + 1;
		}
	}
	return k;
}

}  // namespace k37lag
