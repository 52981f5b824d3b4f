// The servo plants that a skip steps natively (plant.cc), as the backend declares them
// (sim/backends/cxxrtl/backend.py, from k37.hdl.common.observation.FreeRunning). Part of the
// harness's one translation unit (harness.cc).

#pragma once

#include <cstddef>
#include <cstdint>

#include "lag.h"

namespace {

struct Model;

// A servo plant (sim/machine/plant.py; its model: sim/machine/plant_model.py, ServoPlantModel),
// stepped natively while it moves within one encoder count: in the cycles where its phase is
// 0 (every cycle with a period of 0 or 1), v += round((vc - v) alpha / 2^alpha_bits), or
// v = vc if that rounds to 0 (0 if stalled), vc with the feedforward summed (ff) in the first;
// before += v; the count is (before + v) >> frac_bits. A skip ends with the cycle that changes
// a count.
struct Plant {
	size_t velocity, before, dac, dac_zero, gain, alpha, vmax, stall, period, phase, ff;  // items
	unsigned vc_bits, alpha_bits, frac_bits, ff_bits;
};

using k37lag::Lag;

// Step the plants natively for up to `limit` cycles, up to and including the first cycle
// that changes a count (then `crossed`), and return the cycles stepped (their state written).
// That cycle is the skip's last: what reads a plant (its encoder lines, its count) reads the
// position before the cycle's update, still in the old count, and the new count is first
// read by the next cycle, which is evaluated. Exact, and in pieces: while every velocity is
// steady, in closed form; while each ramps (v += s every cycle for a constant rounded step
// s), piece by piece, the position a quadratic in the cycles; a cycle that lands a velocity,
// one at a time; with an update period, the cycles between updates in closed form. `resume`: the plants' states are those the last call left (a skip going on
// past a sample), not read again from the model.
uint64_t advance_plants(Model &m, uint64_t limit, bool resume, bool &crossed);

// Whether a plant's count changed in the last cycle: its position before that cycle's update
// is its `before` register now (before += v), its position now is before + v.
bool plants_moved(Model &m);

}  // namespace
