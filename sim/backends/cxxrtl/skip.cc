// Idle skipping (skip.h): the rate multiplier's decoding, the free-running state's next event,
// advancing that state in closed form, deciding a skip, and the C ABI that declares the state.

#include <algorithm>
#include <vector>

#include "model.h"

extern "C" {

// (skip.h)
unsigned k37_rm_selected_bit(uint64_t state, unsigned width) {
	unsigned ones = 0;
	while (ones < width && (state >> ones & 1))
		ones++;
	return ones < width ? width - 1 - ones : width;
}

// (skip.h)
uint64_t k37_rm_clocks_before_pulse(uint64_t count, uint64_t word, unsigned width) {
	uint64_t first = count + 1, clocks = UINT64_MAX;
	uint64_t bits = width < 64 ? word & ((uint64_t(1) << width) - 1) : word;
	for (; bits; bits &= bits - 1) {
		unsigned t = width - 1 - unsigned(__builtin_ctzll(bits));  // word bit width - 1 - t
		clocks = std::min(clocks, ((uint64_t(1) << t) - 1 - first) & ((uint64_t(2) << t) - 1));
	}
	return clocks;
}

}  // extern "C"

namespace {

// x of a carry accumulator, sign-extended if signed.
int64_t read_x(Model &m, const CarryAccumulator &c) {
	uint64_t raw = read_u64(m, c.x);
	return c.x_signed ? sign_extend(raw, m.items[c.x].width) : int64_t(raw);
}

// The most cycles that can run while accumulator `acc`'s strobe is seen at most `safe` times
// (UINT64_MAX: no limit).
uint64_t cycles_within(Model &m, const Accumulator &acc, uint64_t safe) {
	uint64_t s0 = read_u64(m, acc.stb), inc = read_u64(m, acc.increment);
	if (s0 > safe)
		return 0;
	if (inc == 0)
		return UINT64_MAX;
	// Strobes seen in k cycles: s0 + floor((phase + (k - 1) inc) / 2^w) <= safe.
	u128 limit = (u128(safe - s0 + 1) << acc.width) - read_u64(m, acc.phase);
	u128 top = limit + inc - 1;
	u128 cycles = top >> 64 ? top / inc : uint64_t(top) / uint64_t(inc);
	return cycles < UINT64_MAX ? uint64_t(cycles) : UINT64_MAX;
}

// The most cycles that can run before the next event of the free-running state: a carry
// accumulator's carry, a strobe counter's output pulse while its gate is open, or a countdown
// reaching its stop (UINT64_MAX: none comes), from the current (settled) state.
uint64_t event_horizon(Model &m) {
	uint64_t horizon = UINT64_MAX;
	for (const Countdown &c : m.countdowns) {
		uint64_t count = read_u64(m, c.count);
		if (count != 0)
			horizon = std::min(horizon, count > c.stop ? count - c.stop : 0);
	}
	for (const CarryAccumulator &c : m.carries) {
		int64_t x = read_x(m, c);
		if (x == 0)
			continue;
		uint64_t y = read_u64(m, c.y), full = uint64_t(1) << c.n;
		// Strobes that may come without a carry: y + s x stays in [0, 2^n).
		uint64_t safe = x > 0 ? (full - 1 - y) / uint64_t(x) : y / uint64_t(-x);
		horizon = std::min(horizon, cycles_within(m, m.accumulators[c.clock], safe));
	}
	for (const StrobeCounter &c : m.counters) {
		if (c.gate == SIZE_MAX || !read_u64(m, c.gate))
			continue;
		// The strobes before the first that gives a pulse.
		uint64_t strobes = k37_rm_clocks_before_pulse(read_u64(m, c.count), read_u64(m, c.word),
		                                              c.width);
		if (strobes != UINT64_MAX)
			horizon = std::min(horizon, cycles_within(m, m.accumulators[c.clock], strobes));
	}
	return horizon;
}

// Advance the free-running state by k cycles (k >= 1) in closed form (no carry on the way).
void advance_free(Model &m, uint64_t k) {
	std::vector<uint64_t> &strobes = m.strobes;  // stb highs seen in the k cycles
	strobes.resize(m.accumulators.size());
	for (size_t a = 0; a < m.accumulators.size(); a++) {
		const Accumulator &acc = m.accumulators[a];
		u128 phase = read_u64(m, acc.phase), inc = read_u64(m, acc.increment);
		u128 before_last = phase + u128(k - 1) * inc, total = before_last + inc;
		strobes[a] = read_u64(m, acc.stb) + uint64_t(before_last >> acc.width);
		write_state(m, acc.phase, uint64_t(total & ((u128(1) << acc.width) - 1)));
		write_state(m, acc.stb, uint64_t((total >> acc.width) - (before_last >> acc.width)));
	}
	for (const StrobeCounter &c : m.counters) {
		uint64_t mask = (uint64_t(1) << c.width) - 1;
		uint64_t count = (read_u64(m, c.count) + strobes[c.clock]) & mask;
		write_state(m, c.count, count);
		write_state(m, c.select, k37_rm_selected_bit((count + 1) & mask, c.width));
	}
	for (const CarryAccumulator &c : m.carries) {
		int64_t x = read_x(m, c);
		uint64_t y = read_u64(m, c.y) + uint64_t(int64_t(strobes[c.clock]) * x);
		write_state(m, c.y, y & ((uint64_t(1) << c.n) - 1));
	}
	for (const Countdown &c : m.countdowns) {
		uint64_t count = read_u64(m, c.count);
		if (count != 0)
			write_state(m, c.count, count - k);
	}
}

// (skip.h)
uint64_t try_skip(Model &m, unsigned flags, uint64_t rest, const Item *watch, bool watch_state) {
	if (flags & REST_CHANGED || rest == 0 || plants_moved(m) ||
	    (watch && nonzero(m, *watch, watch_state)))
		return 0;
	if (flags & CHANGED && m.quiet == SIZE_MAX)
		return 0;
	uint64_t skipped = 0;
	// The cycles to the free-running state's next event: computed once, as the skip's samples
	// change nothing it depends on.
	uint64_t horizon = 0;
	bool crossed = false;  // a plant's count changed in the last cycle skipped
	while (skipped < rest) {
		uint64_t to_sample = m.recorder.next - m.cycle;
		uint64_t run = std::min(rest - skipped, to_sample);
		if (flags & CHANGED) {
			if (skipped == 0) {
				refresh_skip_values(m);
				if (!read_u64(m, m.quiet))
					break;
				horizon = event_horizon(m);
			}
			run = advance_plants(m, std::min(run, horizon), skipped != 0, crossed);
			if (run == 0)
				break;
			advance_free(m, run);
			horizon -= run;
			mark_stale(m);
		}
		m.skipped += run;
		skipped += run;
		count_cycles(m, run);
		if (run < to_sample || crossed)
			break;  // an event comes next (a count read, or the free-running state's), or done
	}
	return skipped;
}

}  // namespace

extern "C" {

// Declare a free-running phase accumulator (see Accumulator); returns its number, or -1 if
// phase or stb is not a register of at most 64 bits.
int k37_free_accumulator(void *handle, size_t phase, size_t increment, size_t stb,
                         unsigned width) {
	Model &m = *static_cast<Model *>(handle);
	for (size_t index : {phase, stb})
		if (!is_state(m.items[index]) || m.items[index].width > 64)
			return -1;
	if (width == 0 || width > 63 || m.items[increment].width > 64)
		return -1;
	m.accumulators.push_back(Accumulator{phase, increment, stb, width});
	return int(m.accumulators.size() - 1);
}

// Declare a counter of accumulator `clock`'s strobes (see StrobeCounter; gate SIZE_MAX: its
// pulses never matter); 0, or -1 if the items are not registers or `clock` is not declared.
int k37_free_counter(void *handle, size_t count, size_t select, unsigned width, size_t clock,
                     size_t word, size_t gate) {
	Model &m = *static_cast<Model *>(handle);
	for (size_t index : {count, select})
		if (!is_state(m.items[index]) || m.items[index].width > 64)
			return -1;
	if (width == 0 || width > 63 || clock >= m.accumulators.size())
		return -1;
	m.counters.push_back(StrobeCounter{count, select, width, clock, word, gate});
	return 0;
}

// Declare an accel/decel accumulator clocked by accumulator `clock` (see CarryAccumulator);
// 0, or -1 if y is not a register of n <= 63 bits or `clock` is not declared.
int k37_free_carry(void *handle, size_t y, size_t x, unsigned n, int x_signed, size_t clock) {
	Model &m = *static_cast<Model *>(handle);
	if (!is_state(m.items[y]) || m.items[y].width != n || n == 0 || n > 40 ||
	    m.items[x].width > 63 || clock >= m.accumulators.size())
		return -1;
	m.carries.push_back(CarryAccumulator{y, x, n, x_signed != 0, clock});
	return 0;
}

// Declare a countdown (see Countdown); 0, or -1 if count is not a register of <= 64 bits.
int k37_free_countdown(void *handle, size_t count, uint64_t stop) {
	Model &m = *static_cast<Model *>(handle);
	if (!is_state(m.items[count]) || m.items[count].width > 64)
		return -1;
	m.countdowns.push_back(Countdown{count, stop});
	return 0;
}

// Declare the item that reads non-zero when the free-running state affects nothing else.
void k37_free_quiet(void *handle, size_t index) {
	static_cast<Model *>(handle)->quiet = index;
}

// A self-check of k37_eval_skip (for tests): whether, from the current state, it computes
// items[0 .. n) (of one part each) as a settle does: 1 or 0; -1 if the model has none. It
// leaves the design settled.
int k37_check_eval_skip(void *handle, const size_t *items, size_t n) {
	Model &m = *static_cast<Model *>(handle);
	if (!m.has_eval_skip)
		return -1;
	mark_stale(m);
	refresh_skip_values(m);
	std::vector<uint64_t> fast;
	for (size_t i = 0; i < n; i++)
		fast.push_back(read_u64(m, items[i]));
	settle(m);
	for (size_t i = 0; i < n; i++)
		if (read_u64(m, items[i]) != fast[i])
			return 0;
	return 1;
}

}  // extern "C"
