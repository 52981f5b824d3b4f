// The engine's first-order servo plant (k37.sim.machine.plant.ServoPlant; its model:
// sim/machine/plant_model.py, ServoPlantModel): its inputs, its registers and its update, at
// the gateware's widths. The torque and two-mass drives build on it (drives.h).

#pragma once

#include <cstdint>

#include "blocks.h"

namespace k37e {

// The inputs of one plant (the System's per-axis ports).
struct PlantInputs {
	uint64_t gain = 0, alpha = 0, vmax = 0, kf = 0, period = 0, dac_zero = 0;
	bool stall = false, glitch_a = false, glitch_b = false, break_a = false;
};

// k37.sim.machine.plant.ServoPlant, the first-order drive: velocity lag (updated every
// `period`-th cycle), position, encoder.
struct Plant {
	int64_t velocity = 0;     // VC_BITS + 1 bits
	uint64_t before = 0;      // the position before the last velocity was added
	uint64_t phase = 0;       // cycles since the last velocity update (0: this cycle updates)
	int64_t ff = 0;           // the feedforward summed since the last update
	bool glitch_a = false, glitch_b = false, break_a = false;

	int32_t count() const { return int32_t((before + uint64_t(velocity)) >> FRAC_BITS); }
	Lines lines() const { return lines_at(uint32_t(count())); }
	// The encoder lines at count c (the fault inputs as registered).
	Lines lines_at(uint32_t c) const {
		bool a = (bit(c, 0) != bit(c, 1)) != glitch_a, b = bit(c, 1) != glitch_b;
		return {a, break_a ? a : !a, b, !b};
	}
	// The feedforward of this cycle's update: the sum so far and net command pulse `com`.
	int64_t feedforward(const PlantInputs &in, int com) const {
		return ff + (com > 0 ? int64_t(in.kf) : com < 0 ? -int64_t(in.kf) : 0);
	}
	// The velocity command for D/A word `dac` and the summed feedforward `sum`.
	static int64_t command(const PlantInputs &in, uint64_t dac, int64_t sum) {
		int64_t err = int64_t(dac) - int64_t(in.dac_zero);
		int64_t raw = err * int64_t(in.gain) + sum;
		constexpr int64_t VC_MAX = (int64_t(1) << VC_BITS) - 1;
		int64_t vmax = in.vmax == 0 || in.vmax > uint64_t(VC_MAX) ? VC_MAX : int64_t(in.vmax);
		return raw > vmax ? vmax : raw < -vmax ? -vmax : raw;
	}
	// The velocity after an update towards the velocity command `vc`.
	int64_t next_velocity(const PlantInputs &in, int64_t vc) const {
		int64_t delta = int64_t(uint64_t(vc - velocity) * in.alpha + (uint64_t(1) << (ALPHA_BITS - 1)));
		int64_t step = delta >> ALPHA_BITS;
		return in.stall ? 0 : step == 0 ? vc : wrap(velocity + step, VC_BITS + 1);
	}
	// Whether the plant updates as the papers' plant, every cycle, with nothing summed.
	bool every_cycle(const PlantInputs &in) const { return in.period <= 1 && phase == 0 && ff == 0; }
	void rise(const PlantInputs &in, uint64_t dac, int com) {
		int64_t sum = feedforward(in, com);
		bool update = phase == 0;
		take(in, update ? next_velocity(in, command(in, dac, sum)) : velocity, update, sum);
	}
	// The edge's registers: the position takes the velocity, which becomes `next`; the
	// update's phase and the feedforward's sum (`sum` with this cycle's pulse) move on.
	void take(const PlantInputs &in, int64_t next, bool update, int64_t sum) {
		before += uint64_t(velocity);
		velocity = next;
		phase = phase + 1 >= in.period ? 0 : phase + 1;
		ff = update ? 0 : sum;
		glitch_a = in.glitch_a;
		glitch_b = in.glitch_b;
		break_a = in.break_a;
	}
};

}  // namespace k37e
