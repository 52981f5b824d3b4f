// The firmware's polling wait, run natively (wait.cc): its arguments and why it returns. The
// backend mirrors both (sim/backends/cxxrtl/backend.py: _WaitPolling, WaitEnd), field for
// field and value for value. Part of the harness's one translation unit (harness.cc).

#pragma once

#include <cstddef>
#include <cstdint>

// A halted wait for an interrupt with a timer routine that only reads (k37_wait_polling, in
// wait.cc, tells what each does).
struct WaitPolling {
	size_t irq;             // item: the interrupt, pending while it reads non-zero
	const size_t *bus;      // items of the host bus: addr, r_stb, r_data
	uint64_t limit;         // cycles at most
	uint64_t pause;         // cycles after which the caller acts (between two cycles)
	uint64_t period;        // the timer's period: its ticks at its multiples
	const uint64_t *ports;  // addresses the routines read, n of them
	const uint64_t *stops;  // per port, the bits that end the wait when a byte read has one
	size_t n;               // ports
	const uint64_t *idles;  // per routine, n + 1 idle cycles: before each read, then after
	uint64_t routines;      // routines in idles
	int due;                // the first routine is due at once
	int skip_idle;          // idle cycles are stepped as k37_step with skip_idle
};

// Why k37_wait_polling returned.
enum class WaitEnd : int {
	OVER = 0,        // an interrupt is pending after a wait, or `limit` ran out
	STOPPED = 1,     // a routine read a byte with a bit of its port's stop mask set
	PAUSED = 2,      // `pause` cycles passed, or the routines ran out: the same wait goes on
	PAUSED_DUE = 3,  // the same, at a tick whose routine is due: come back with `due`
};

extern "C" {

WaitEnd k37_wait_polling(void *handle, const WaitPolling *wait, uint64_t *done, uint64_t *bytes);

}  // extern "C"
