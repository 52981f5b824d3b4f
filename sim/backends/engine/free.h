// The engine's closed forms for the state that runs on by itself while the machine is quiet
// (the idle skipping of machine.h): a phase accumulator's strobes over k cycles, the rate
// multiplier's next pulse, and how many cycles keep a number of strobes. The same arithmetic
// as the compiled RTL backend's skip.cc states over the RTL's registers; here over the engine's
// own (tests/sim/backends/test_engine_free.py pins it to the reference models).

#pragma once

#include <algorithm>
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

// `v`'s low `width` bits in reverse order (width <= 64).
inline uint64_t reversed(uint64_t v, unsigned width) {
	v = (v >> 1 & 0x5555555555555555) | (v & 0x5555555555555555) << 1;
	v = (v >> 2 & 0x3333333333333333) | (v & 0x3333333333333333) << 2;
	v = (v >> 4 & 0x0f0f0f0f0f0f0f0f) | (v & 0x0f0f0f0f0f0f0f0f) << 4;
	return __builtin_bswap64(v) >> (64 - width);
}

// The rate multiplier's input clocks that pass without a pulse from counter state `count` on
// (clock i, from 0, reaches state count + 1 + i): the fewest before a state that selects a set
// bit of `word`; UINT64_MAX if `word` is 0. State s selects bit width - 1 - t, t its trailing
// ones; the states with t trailing ones are those equal to 2^t - 1 modulo 2^(t + 1), and the
// first of them from state f on is k_t = (2^t - 1 - f) mod 2^(t + 1) clocks away: the low t
// bits of ~f if bit t of f is 0, else 2^t more. Among the t of each kind the least gives the
// fewest clocks, so two candidates remain.
inline uint64_t clocks_before_pulse(uint64_t count, uint64_t word, unsigned width) {
	uint64_t selected = reversed(word, width);  // bit t: the bit the states of t ones select
	uint64_t f = count + 1, clocks = UINT64_MAX;
	if (uint64_t clear = selected & ~f) {
		unsigned t = unsigned(__builtin_ctzll(clear));
		clocks = ~f & ((uint64_t(1) << t) - 1);
	}
	if (uint64_t set = selected & f) {
		unsigned t = unsigned(__builtin_ctzll(set));
		clocks = std::min(clocks, (uint64_t(1) << t) | (~f & ((uint64_t(1) << t) - 1)));
	}
	return clocks;
}

}  // namespace k37e
