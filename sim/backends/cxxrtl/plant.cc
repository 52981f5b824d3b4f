// The servo plants stepped natively (plant.h): their state read from the model and advanced
// by the plant's update of lag.h, exact over the pieces of a skip in which no count changes,
// and the C ABI that declares a plant.

#include <algorithm>
#include <cmath>
#include <vector>

#include "model.h"

namespace {

// The velocity command of plant `p` for the summed feedforward `sum`.
int64_t command(Model &m, const Plant &p, int64_t sum) {
	int64_t err = int64_t(read_u64(m, p.dac)) - int64_t(read_u64(m, p.dac_zero));
	int64_t raw = err * int64_t(read_u64(m, p.gain)) + sum;
	int64_t top = (int64_t(1) << p.vc_bits) - 1;
	uint64_t limit = read_u64(m, p.vmax);
	int64_t vmax = limit == 0 || limit > uint64_t(top) ? top : int64_t(limit);
	return raw > vmax ? vmax : raw < -vmax ? -vmax : raw;
}

// The state of plant `p` (its registers and inputs) in the model.
Lag lag_of(Model &m, const Plant &p) {
	int64_t v = sign_extend(read_u64(m, p.velocity), p.vc_bits + 1);
	Lag lag(v, command(m, p, 0), int64_t(read_u64(m, p.alpha)),
	        read_u64(m, p.before) + uint64_t(v), read_u64(m, p.stall) != 0, p.vc_bits,
	        p.alpha_bits, p.frac_bits);
	lag.hold(read_u64(m, p.period), read_u64(m, p.phase),
	         command(m, p, sign_extend(read_u64(m, p.ff), p.ff_bits)));
	return lag;
}

// (plant.h)
uint64_t advance_plants(Model &m, uint64_t limit, bool resume, bool &crossed) {
	crossed = false;
	if (m.plants.empty() || limit == 0)
		return limit;
	std::vector<Lag> &states = m.plant_states;
	if (!resume) {
		states.clear();
		for (const Plant &p : m.plants)
			states.push_back(lag_of(m, p));
	}
	m.plant_steps.resize(states.size());
	bool every = std::all_of(states.begin(), states.end(),
	                         [](const Lag &s) { return s.every_cycle(); });
	uint64_t k = every ? k37lag::advance(states.data(), states.size(), m.plant_steps.data(),
	                                     limit, crossed)
	                   : k37lag::advance_held(states.data(), states.size(), limit, crossed);
	for (size_t i = 0; i < states.size(); i++) {
		const Plant &p = m.plants[i];
		write_state(m, p.velocity, uint64_t(states[i].v) & ((uint64_t(1) << (p.vc_bits + 1)) - 1));
		write_state(m, p.before, states[i].position - uint64_t(states[i].v));
		write_state(m, p.phase, states[i].phase);
		if (!states[i].pending)
			write_state(m, p.ff, 0);
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

// Declare a servo plant (see Plant); 0, or -1 if velocity, before, phase or ff is not a
// register, or they are not as wide as the format says (the position, before, must be the 64
// bits that the native steps compute in; the summed feedforward at most 64).
int k37_free_plant(void *handle, const size_t *items, unsigned vc_bits, unsigned alpha_bits,
                   unsigned frac_bits) {
	Model &m = *static_cast<Model *>(handle);
	Plant p{items[0], items[1], items[2], items[3], items[4], items[5], items[6], items[7],
	        items[8], items[9], items[10], vc_bits, alpha_bits, frac_bits,
	        unsigned(m.items[items[10]].width)};
	if (!is_state(m.items[p.velocity]) || m.items[p.velocity].width != vc_bits + 1 ||
	    !is_state(m.items[p.before]) || m.items[p.before].width != 64 ||
	    !is_state(m.items[p.phase]) || !is_state(m.items[p.ff]) || p.ff_bits > 64)
		return -1;
	m.plants.push_back(p);
	return 0;
}

}  // extern "C"
