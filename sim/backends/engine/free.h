// The engine's closed forms for the state that runs on by itself while the machine is quiet
// (the idle skipping of machine.h): a phase accumulator's strobes over k cycles, the rate
// multiplier's next pulse, and how many cycles keep a number of strobes. The same arithmetic
// as the compiled RTL backend's skip.cc states over the RTL's registers; here over the engine's
// own (tests/sim/backends/test_engine_free.py pins it to the reference models).

#pragma once

#include <cstdint>

namespace k37e {

using u128 = unsigned __int128;

// A phase accumulator's strobes seen in the next k cycles (k >= 1): the strobe it holds now,
// then the carries of the first k - 1 additions.
inline uint64_t strobes_seen(uint64_t phase, uint64_t increment, bool stb, unsigned width,
                             uint64_t k) {
	return uint64_t(stb) + uint64_t((u128(phase) + u128(k - 1) * increment) >> width);
}

// The most cycles in which a phase accumulator's strobe is seen at most `safe` times
// (UINT64_MAX: no limit).
inline uint64_t cycles_within(uint64_t phase, uint64_t increment, bool stb, unsigned width,
                              uint64_t safe) {
	if (uint64_t(stb) > safe)
		return 0;
	if (increment == 0)
		return UINT64_MAX;
	// strobes_seen(k) <= safe: stb + floor((phase + (k - 1) inc) / 2^w) <= safe.
	u128 limit = (u128(safe - uint64_t(stb) + 1) << width) - phase;
	if (limit >> 64 == 0)  // the common case, in one 64-bit division
		return uint64_t(limit) / increment + (uint64_t(limit) % increment != 0);
	u128 cycles = (limit + increment - 1) / increment;
	return cycles < UINT64_MAX ? uint64_t(cycles) : UINT64_MAX;
}

// The rate multiplier's input clocks that pass without a pulse from counter state `count` on
// (clock i, from 0, reaches state count + 1 + i): the fewest before a state that selects a set
// bit of `word` (state s selects bit width - 1 - t, t its trailing ones; the states with t
// trailing ones are those equal to 2^t - 1 modulo 2^(t + 1)); UINT64_MAX if `word` is 0.
inline uint64_t clocks_before_pulse(uint64_t count, uint64_t word, unsigned width) {
	uint64_t first = count + 1, clocks = UINT64_MAX;
	for (uint64_t bits = word & ((uint64_t(1) << width) - 1); bits; bits &= bits - 1) {
		unsigned t = width - 1 - unsigned(__builtin_ctzll(bits));
		uint64_t k = ((uint64_t(1) << t) - 1 - first) & ((uint64_t(2) << t) - 1);
		clocks = k < clocks ? k : clocks;
	}
	return clocks;
}

}  // namespace k37e
