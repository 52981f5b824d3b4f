// The firmware's polling wait, run natively (wait.h): the host's halted wait for an interrupt
// with a timer routine that only reads, as k37.firmware_model.host.Host8085.wait_polling's own loop
// of waits, idle cycles and bus reads runs it (k37.sim.backends.contract.Backend.wait_polling).

#include "model.h"
#include "wait.h"

namespace {

// k37_wait_polling on a model; `done` counts the routines run to their end.
WaitEnd wait_polling(Model &m, const WaitPolling &w, uint64_t &done, uint64_t *bytes) {
	const Item &item = m.items[w.irq];
	const uint64_t start = m.cycle;
	const bool skip_idle = w.skip_idle != 0;
	bool due = w.due != 0;
	for (done = 0;; done++) {
		uint64_t to_tick = 0, waited = 1;
		while (!due && (waited != to_tick || m.cycle - start >= w.limit)) {
			// wait up to the next tick that comes before the limit
			uint64_t elapsed = m.cycle - start;
			if (elapsed >= w.limit)
				return WaitEnd::OVER;
			if (elapsed >= w.pause || done == w.routines)
				return WaitEnd::PAUSED;
			to_tick = w.period - m.cycle % w.period;
			uint64_t wait = std::min(w.limit - elapsed, to_tick);
			bool paused = elapsed + wait > w.pause;
			waited = run_until(m, item, paused ? w.pause - elapsed : wait, skip_idle);
			if (nonzero(m, item, is_state(item)))
				return WaitEnd::OVER;
			if (paused)
				return WaitEnd::PAUSED;
		}
		if (!due && m.cycle - start >= w.pause)
			return WaitEnd::PAUSED_DUE;  // the routine of this tick is due: after the pause
		due = false;
		const uint64_t *idle = w.idles + done * (w.n + 1);
		bool stop = false;
		for (size_t j = 0; j < w.n; j++) {
			step(m, idle[j], skip_idle);
			bytes[j] = bus_read(m, w.bus, w.ports[j]);
			stop |= (bytes[j] & w.stops[j]) != 0;
		}
		if (stop)
			return WaitEnd::STOPPED;
		step(m, idle[w.n], skip_idle);
	}
}

}  // namespace

extern "C" {

// The host's halted wait for an interrupt (item `irq` reads non-zero after a cycle) with a
// timer routine that only reads: at most `limit` cycles; at each tick (a multiple of `period`)
// that a wait reached without an interrupt, while `limit` had not run out, routine k (of
// `routines`) idles idles[k (n + 1) + j] cycles before reading port j (of n, on the host bus
// `bus`), then idles[k (n + 1) + n] after. Idle cycles are stepped as k37_step with
// `skip_idle`. With `due`, the first routine is due at once (a call that returned PAUSED_DUE
// was at its tick). Sets *done to the routines run to their end and returns why it returned
// (WaitEnd): OVER, an interrupt is pending after a wait or `limit` ran out; STOPPED, routine
// number *done read a byte with a bit of its port's stops[j] set, its bytes in bytes[0 .. n)
// (its last idle cycles not run); PAUSED (come back: the same wait goes on), `pause` cycles
// have passed (the caller acts between cycles) or the routines ran out; PAUSED_DUE, the same
// at a tick whose routine is due (come back with `due`).
WaitEnd k37_wait_polling(void *handle, const WaitPolling *wait, uint64_t *done, uint64_t *bytes) {
	return wait_polling(*static_cast<Model *>(handle), *wait, *done, bytes);
}

}  // extern "C"
