// Idle skipping: the free-running state that a skip advances in closed form (skip.cc), as the
// backend declares it (sim/backends/cxxrtl/backend.py, from
// k37.hdl.common.observation.FreeRunning), and
// the rate multiplier's decoding that tells when its next pulse comes. Part of the harness's
// one translation unit (harness.cc).

#pragma once

#include <cstddef>
#include <cstdint>

extern "C" {

// The rate multiplier's decoding (hdl/feed/rate_multiplier.py), as its reference model defines it
// (hdl/feed/model/rate_multiplier.py; tests/hdl/feed/test_rate_multiplier.py pins these to it):
// counter state `state` of a `width`-bit cascade passes the input clock for word bit
// width - 1 - t, t its trailing ones, and for none (width) when it is all ones. The states
// with t trailing ones are those equal to 2^t - 1 modulo 2^(t + 1).
unsigned k37_rm_selected_bit(uint64_t state, unsigned width);

// Input clocks that pass without a pulse from counter state `count` on (clock i, from 0,
// reaches state count + 1 + i): the fewest before a state that selects a set bit of `word`,
// UINT64_MAX if `word` is 0.
uint64_t k37_rm_clocks_before_pulse(uint64_t count, uint64_t word, unsigned width);

}  // extern "C"

namespace {

struct Item;
struct Model;

// A phase accumulator that runs on by itself (hdl/feed/divider.py): phase += increment at every
// rising edge, stb holds the carry out of the last addition.
struct Accumulator {
	size_t phase, increment, stb;  // item indices
	unsigned width;
};

// A counter (the rate multiplier's, hdl/feed/rate_multiplier.py) that counts the cycles in which
// accumulator `clock`'s stb is high; `select` is the word bit that state count + 1 selects
// (k37_rm_selected_bit).
struct StrobeCounter {
	size_t count, select;
	unsigned width;
	size_t clock;
	// Its output: a pulse in a strobe cycle iff the word bit selected is set. While `gate`
	// reads non-zero, the pulses matter and skips stop before the next one.
	size_t word, gate;
};

// An accel/decel accumulator (hdl/accel/exponential.py): at each strobe of accumulator `clock`,
// y += x, and a carry out of its n bits moves a count from x to its output. Skips stop before
// its next carry; x (and everything the carry feeds) is ordinary state.
struct CarryAccumulator {
	size_t y, x;
	unsigned n;
	bool x_signed;
	size_t clock;
};

// A register that goes down by one each cycle while it is not 0 (the K3701's step latency
// count); skips stop before it reaches `stop`.
struct Countdown {
	size_t count;
	uint64_t stop;
};

// After a cycle whose commits returned `flags` (the clock high): if it changed no state but
// the free-running state's, no plant's count, and the quiet item reads 1, the rest of the
// design is at a fixed point until the next event of the free-running state; skip up to `rest`
// cycles, to just before that event, advancing the free-running state exactly. Not if item
// `watch` (when given) reads non-zero. A recorder sample on the way is taken (as after a
// stepped cycle) and the skip goes on from it, the rest still at its fixed point.
// Returns the cycles skipped.
uint64_t try_skip(Model &m, unsigned flags, uint64_t rest, const Item *watch = nullptr,
                  bool watch_state = false);

}  // namespace
