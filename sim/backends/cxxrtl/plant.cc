// The servo plants stepped natively (plant.h): the C++ twin of a plant's update, exact over the
// pieces of a skip in which no count changes, and the C ABI that declares a plant.

#include <algorithm>
#include <cmath>
#include <vector>

#include "model.h"

namespace {

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

// One plant's registers and (constant) inputs, and its update, as the gateware
// (sim/machine/plant.py) and its model (sim/machine/plant_model.py, ServoPlantModel.cycle)
// compute them: the position (before + v, what the count is taken from) and the velocity.
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

// (plant.h)
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

// (plant.h)
bool plants_moved(Model &m) {
	for (const Plant &p : m.plants) {
		uint64_t before = read_u64(m, p.before);
		uint64_t v = uint64_t(sign_extend(read_u64(m, p.velocity), p.vc_bits + 1));
		if ((before + v) >> p.frac_bits != before >> p.frac_bits)
			return true;
	}
	return false;
}

}  // namespace

extern "C" {

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

}  // extern "C"
