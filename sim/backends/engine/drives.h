// The engine's servo drives: the first-order plant (blocks.h, Plant), the torque drive
// (k37.sim.machine.torque_drive.TorqueDrive; its model: sim/machine/torque_drive_model.py) and
// the two-mass drive (k37.sim.machine.two_mass.TwoMassDrive; sim/machine/two_mass_model.py),
// with each register as wide as the gateware's and every sum exact before it is stored, as
// Amaranth computes it. While the machine is quiet, the plants are stepped alone
// (advance_drives): all at rest, in one jump; else cycle by cycle up to the cycle that changes
// an encoder count, the chips' free-running state jumped.

#pragma once

#include <algorithm>
#include <cstdint>

#include "plant.h"

namespace k37e {

using i128 = __int128;

// Two's complement wrap of v to `bits` bits (bits <= 127), as a register of that width holds it.
inline i128 wrap128(i128 v, unsigned bits) {
	unsigned drop = 128 - bits;
	return i128((unsigned __int128)v << drop) >> drop;
}

// The drive of an axis (the System's `drives`, k37.sim.machine.system.DRIVES).
enum class DriveKind { FIRST_ORDER = 0, TORQUE = 1, TWO_MASS = 2 };

// The drive's own inputs, by the System's names of its ports (TORQUE_INPUTS, TWO_MASS_INPUTS).
enum DrivePort { BETA, KI, FC, LOAD, LOAD_STEP, LOAD_AFTER, KS_M, KS_T, CS_M, CS_T, SCALE,
                 DRIVE_PORT_COUNT };
const char *const DRIVE_PORTS[] = {"beta", "ki", "fc", "load", "load_step", "load_after",
                                   "ks_m", "ks_t", "cs_m", "cs_t", "scale"};

// `velocity` less Coulomb friction `fc`, which never reverses it.
inline i128 coulomb(i128 velocity, i128 fc) {
	return velocity > fc ? velocity - fc : velocity < -fc ? velocity + fc : 0;
}

// One axis's drive: the first-order plant's registers (Plant), and the torque drive's
// integrator and load-step count, the two-mass drive's table velocity and spring deflection.
struct Drive : Plant {
	DriveKind kind = DriveKind::FIRST_ORDER;
	uint64_t port[DRIVE_PORT_COUNT] = {};  // the drive's inputs, raw (load, load_step signed)
	i128 integral = 0;                     // INTEGRAL_BITS
	uint64_t elapsed = 0;                  // AFTER_BITS
	int64_t table = 0;                     // VC_BITS + 1: the table's velocity
	uint64_t spring_before = 0;            // the deflection less (velocity - table)

	int64_t load(int p) const { return sext(port[p], unsigned(ACCEL_BITS)); }
	// The spring's deflection s now (the motor's position less the table's).
	uint64_t deflection() const { return spring_before + uint64_t(velocity) - uint64_t(table); }
	int32_t count() const {
		uint64_t position = before + uint64_t(velocity);
		if (kind == DriveKind::TWO_MASS && port[SCALE])
			position -= deflection();
		return int32_t(position >> FRAC_BITS);
	}
	Lines lines() const { return lines_at(uint32_t(count())); }

	// The load and, from cycle load_after on, the load step (advances the count).
	i128 disturbance() {
		bool counting = port[LOAD_STEP] != 0;
		bool stepped = counting && elapsed >= port[LOAD_AFTER];
		if (counting && !stepped)
			elapsed = (elapsed + 1) & low_bits(unsigned(AFTER_BITS));
		return i128(load(LOAD)) + (stepped ? load(LOAD_STEP) : 0);
	}
	// The velocity after the velocity loop's torque and the viscous friction (advances the
	// integral).
	i128 loop_velocity(const PlantInputs &in, int64_t vc) {
		i128 v = velocity, ev = i128(vc) - v;
		integral = wrap128(integral + ev * i128(port[KI]), unsigned(INTEGRAL_BITS));
		i128 drive = (ev * i128(in.alpha) - v * i128(port[BETA]) + (i128(1) << (ALPHA_BITS - 1)))
		             >> ALPHA_BITS;
		return v + drive + (integral >> KI_FRAC);
	}
	// The torque or two-mass drive's next motor velocity (updating its other registers).
	int64_t next_drive_velocity(const PlantInputs &in, int64_t vc) {
		constexpr unsigned WIDE = unsigned(VC_BITS) + 4, V = unsigned(VC_BITS) + 1;
		if (kind == DriveKind::TORQUE) {
			i128 loop = loop_velocity(in, vc);
			i128 v1 = wrap128(loop - disturbance(), WIDE);
			return in.stall ? 0 : int64_t(wrap128(coulomb(v1, i128(port[FC])), V));
		}
		i128 s = int64_t(deflection()), slip = i128(velocity) - table;
		i128 half = i128(1) << (SPRING_FRAC - 1);
		i128 fm = (s * i128(port[KS_M]) + slip * i128(port[CS_M]) + half) >> SPRING_FRAC;
		i128 ft = (s * i128(port[KS_T]) + slip * i128(port[CS_T]) + half) >> SPRING_FRAC;
		i128 motor = wrap128(loop_velocity(in, vc) - fm, WIDE);
		i128 table_next = wrap128(table + ft - disturbance(), WIDE);
		spring_before = uint64_t(int64_t(s));
		table = in.stall ? 0 : int64_t(wrap128(coulomb(table_next, i128(port[FC])), V));
		return in.stall ? 0 : int64_t(wrap128(motor, V));
	}
	// The clock edge, for D/A word `dac` and net command pulse `com`.
	void rise(const PlantInputs &in, uint64_t dac, int com) {
		if (kind == DriveKind::FIRST_ORDER) {
			Plant::rise(in, dac, com);
			return;
		}
		int64_t sum = feedforward(in, com);
		bool update = phase == 0;
		int64_t next = next_drive_velocity(in, command(in, dac, sum));  // its other registers
		take(in, update ? next : velocity, update, sum);
	}
	// Whether an edge with no command pulse leaves every register as it is (the load-step
	// count aside): the drive is at rest, updated every cycle.
	bool at_rest(const PlantInputs &in, uint64_t dac) const {
		if (!every_cycle(in))
			return false;  // an update period's phase moves on: stepped
		Drive next = *this;
		next.rise(in, dac, 0);
		return velocity == 0 && next.velocity == 0 && next.integral == integral &&
		       next.table == table && next.spring_before == spring_before;
	}
	// The cycles before the load step acts (UINT64_MAX: it does not come).
	uint64_t before_load_step() const {
		return port[LOAD_STEP] != 0 && elapsed < port[LOAD_AFTER] ? port[LOAD_AFTER] - elapsed
		                                                           : UINT64_MAX;
	}
	// k cycles at rest (at most before_load_step()).
	void rest(uint64_t k) {
		if (before_load_step() != UINT64_MAX)
			elapsed += k;
	}
};

// Step the drives of n axes alone (their D/A words `dacs` held, no command pulse) for at most
// h cycles, up to and including the first cycle that changes an encoder count; the cycles run.
// All at rest: one jump, up to the first load step.
inline uint64_t advance_drives(Drive *const *drives, const PlantInputs *const *ins,
                               const uint64_t *dacs, int n, uint64_t h) {
	bool rest = true;
	for (int i = 0; i < n && rest; i++) {
		rest = drives[i]->at_rest(*ins[i], dacs[i]);
		h = std::min(h, drives[i]->before_load_step());
	}
	if (rest) {
		for (int i = 0; i < n; i++)
			drives[i]->rest(h);
		return h;
	}
	for (uint64_t k = 1;; k++) {
		bool moved = false;
		for (int i = 0; i < n; i++) {
			int32_t count = drives[i]->count();
			drives[i]->rise(*ins[i], dacs[i], 0);
			moved |= drives[i]->count() != count;
		}
		if (moved || k >= h)
			return k;
	}
}

}  // namespace k37e
