// The engine's axes (each an accel/decel circuit after the K3701, a K3702, an encoder interface
// and a servo drive, as k37.sim.machine.system.System wires them) and how they run alone
// between the chips' events: the drives and the encoder interfaces' filter streaks, up to the
// cycle in which a filter passes a change.
//
// First-order plants updated every cycle (the papers' plant) run lazily: each keeps its
// registers as they were some cycles `behind` the present, and the cycle of its next count
// change, looked ahead once from them (lag.h) while its inputs hold. A stretch that ends
// before that cycle costs the plant nothing; the registers are brought to the present
// (sync) only where the plant's inputs change (its K3702's D/A word, a feedforward pulse, a
// port written), or at the count change itself (the state looked ahead is taken).
// Plants with an update period and the torque and two-mass drives are run at every stretch.

#pragma once

#include <algorithm>

#include "blocks.h"
#include "drives.h"
#include "lag.h"

namespace k37e {

constexpr int MAX_AXES = 3;

struct Axis {
	Circuit post;  // the accel/decel circuit after the K3701 (post placement)
	K3702 ctrl;
	Encoder enc;
	Drive plant;
	PlantInputs in;
	uint64_t max_abs_error = 0;
	uint32_t pulses_pos = 0, pulses_neg = 0;
};

struct Axes {
	const int axes;
	Axis axis[MAX_AXES];
	bool drives = false;  // an axis has a torque or two-mass drive (set_drive)

	// A lazily run plant's next count change: `known` while its inputs hold since it was
	// looked ahead; its registers are `behind` cycles before the present; `in` cycles from
	// the present up to and including the cycle of the change, after which it is `at`. Before
	// it is looked ahead, a bound: `clear` cycles from the present keep the count (`bounded`).
	struct Ahead {
		bool known = false, bounded = false;
		uint64_t behind = 0, in = 0, clear = 0;
		k37lag::Lag at;
	};
	Ahead ahead[MAX_AXES];
	// Cycles from the present in which nothing of the axes changes (no plant's count, every
	// encoder interface at rest): advance_plants only counts them, `owed` to each plant's
	// Ahead until it is next used (pay).
	uint64_t calm = 0, owed = 0;
	void pay() {
		if (!owed)
			return;
		for (int i = 0; i < axes; i++) {
			Ahead &a = ahead[i];
			a.behind += owed;
			(a.known ? a.in : a.clear) -= owed;
		}
		owed = 0;
	}
	// How far a plant is looked ahead for its next count change (one that does not come
	// within it ends the look at its end).
	static constexpr uint64_t LOOK = uint64_t(1) << 40;

	explicit Axes(int n) : axes(n) {}

	// Axis k's drive (a DriveKind).
	void set_drive(int k, int kind) {
		sync_all();
		axis[k].plant.kind = DriveKind(kind);
		drives |= kind != int(DriveKind::FIRST_ORDER);
	}

	// Step the plants and the encoder interfaces alone for at most h cycles (the plants' D/A
	// words and inputs held, no command pulse), up to and including the first cycle in which
	// an encoder interface's filter passes a change; the cycles run. The plants in pieces,
	// exactly (lag.h, as the compiled RTL backend's skips step them), each ending at a count
	// change; over each piece the encoders see the lines it started with, their filter
	// streaks advanced in closed form (Encoder::advance); the cycle in which a filter passes a
	// change runs the encoders' whole edge (its count pulse ends the stretch).
	uint64_t advance_plants(uint64_t h) {
		if (h <= calm) {  // nothing of the axes changes: only counted
			calm -= h;
			owed += h;
			return h;
		}
		uint64_t done = 0;
		bool rest = true;  // every encoder interface rests on the lines of the last piece
		while (done < h) {
			uint64_t piece = h - done;
			Lines in[MAX_AXES];
			rest = true;
			for (int i = 0; i < axes; i++) {
				in[i] = axis[i].plant.lines();
				if (!axis[i].enc.rests(in[i])) {
					rest = false;
					piece = std::min(piece, axis[i].enc.steady_cycles(in[i]));
				}
			}
			if (piece == 0) {
				for (int i = 0; i < axes; i++)
					axis[i].enc.rise(in[i]);
				done += run_plants(1);
				rest = false;
				break;
			}
			uint64_t k = run_plants(piece);
			if (!rest)
				for (int i = 0; i < axes; i++)
					axis[i].enc.advance(in[i], k);
			done += k;
		}
		// calm: no count changed in the last piece, so the lines are the piece's
		for (int i = 0; i < axes && calm && !rest; i++)
			if (!axis[i].enc.rests(axis[i].plant.lines()))
				calm = 0;
		return done;
	}
	// Run the plants alone for at most n cycles, up to and including the first cycle that
	// changes a count; the cycles run. The torque and two-mass drives stepped; first-order
	// plants with an update period held between updates (lag.h, advance_held); else lazily.
	uint64_t run_plants(uint64_t n) {
		calm = 0;
		if (drives)
			return advance_drives(n);
		for (int i = 0; i < axes; i++)
			if (!axis[i].plant.every_cycle(axis[i].in))
				return hold_plants(n);
		return lazy_plants(n);
	}
	// run_plants of plants updated every cycle: each bounded, or looked ahead to its next
	// count change where the bound is short of the cycles, then left behind, or brought to
	// the change if it comes first.
	uint64_t lazy_plants(uint64_t n) {
		pay();
		for (int i = 0; i < axes; i++) {
			Ahead &a = ahead[i];
			if (!a.known) {
				if (!a.bounded) {
					a.clear = clear_cycles(i);
					a.bounded = true;
				}
				if (a.clear >= n)
					continue;
				look(i);
			}
			n = std::min(n, a.in);
		}
		for (int i = 0; i < axes; i++) {
			Ahead &a = ahead[i];
			a.behind += n;
			if (!a.known) {
				a.clear -= n;
			} else if ((a.in -= n) == 0) {
				take(axis[i].plant, a.at);
				a.behind = 0;
				a.known = a.bounded = false;
			}
		}
		calm = UINT64_MAX;  // the cycles before any plant's count can change
		for (int i = 0; i < axes; i++) {
			const Ahead &a = ahead[i];
			calm = std::min(calm, a.known ? a.in - 1 : a.bounded ? a.clear : 0);
		}
		return n;
	}
	// The cycles from plant i's registers (not behind) that surely keep its count (Lag::clear).
	uint64_t clear_cycles(int i) const { return lag(axis[i], axis[i].ctrl.dac).clear(); }
	// Look plant i ahead to its next count change, from the present (its registers brought
	// there first): jumped by its bound (the change comes after it, often just after), stepped
	// over the next cycles, then in closed form.
	void look(int i) {
		Ahead &a = ahead[i];
		sync(i, axis[i].ctrl.dac);
		k37lag::Lag l = lag(axis[i], axis[i].ctrl.dac);
		uint64_t k = l.clear();
		if (k < LOOK)
			l.run(k);
		else
			k = 0;
		bool crossed = false;
		for (uint64_t j = 0; j < STEPPED_LOOK && !crossed; j++) {
			l.take(l.next_v());
			crossed = l.left_count();
			k++;
		}
		if (!crossed) {
			int64_t scratch;
			k += k37lag::advance(&l, 1, &scratch, LOOK, crossed);
		}
		a.at = l;
		a.in = k;
		a.known = true;
	}
	// Bring plant i's registers to the present, `dac` its D/A word over the cycles behind.
	void sync(int i, uint64_t dac) {
		pay();
		Ahead &a = ahead[i];
		if (!a.behind)
			return;
		Plant &p = axis[i].plant;
		if (a.behind <= STEPPED_PIECE) {
			int64_t vc = Plant::command(axis[i].in, dac, 0);
			for (uint64_t j = 0; j < a.behind; j++) {
				p.before += uint64_t(p.velocity);
				p.velocity = p.next_velocity(axis[i].in, vc);
			}
		} else {
			k37lag::Lag l = lag(axis[i], dac);
			l.run(a.behind);
			take(p, l);
		}
		a.behind = 0;
	}
	void sync_all() {
		for (int i = 0; i < axes; i++)
			sync(i, axis[i].ctrl.dac);
	}
	// Plant i's inputs change: its registers are brought to the present (`dac` its D/A word
	// over the cycles behind) and its next count change is looked ahead again.
	void forget(int i, uint64_t dac) {
		sync(i, dac);
		calm = 0;
		ahead[i].known = ahead[i].bounded = false;
	}
	// Plant i's edge as the whole machine steps, with command pulse `com`, where it is
	// looked ahead and the pulse changes nothing of its update (no feedforward): it stays
	// behind one cycle more, or takes the count change that comes in it; true if so.
	bool coast(int i, int com) {
		pay();
		calm = 0;
		Ahead &a = ahead[i];
		if (!a.known && !(a.bounded && a.clear)) {  // stepped: brought to the present first
			sync(i, axis[i].ctrl.dac);
			a.bounded = false;
			return false;
		}
		if (com && axis[i].in.kf) {
			forget(i, axis[i].ctrl.dac);
			return false;
		}
		if (!a.known) {
			a.clear--;
			a.behind++;
		} else if (--a.in == 0) {
			take(axis[i].plant, a.at);
			a.behind = 0;
			a.known = a.bounded = false;
		} else {
			a.behind++;
		}
		return true;
	}

	// Pieces of at most this many cycles are stepped cycle by cycle (Plant::rise): cheaper
	// than the closed forms' set-up over a few cycles, and the same update.
	static constexpr uint64_t STEPPED_PIECE = 16;
	// A look ahead steps this many cycles past its bound before it goes on in closed form.
	static constexpr uint64_t STEPPED_LOOK = 16;
	// A plant's registers from the state lag.h advanced it to.
	static void take(Plant &p, const k37lag::Lag &lag) {
		p.velocity = lag.v;
		p.before = lag.position - uint64_t(lag.v);
		p.phase = lag.phase;
		if (!lag.pending)
			p.ff = 0;
	}
	// run_plants of first-order plants with an update period.
	uint64_t hold_plants(uint64_t n) { return axes == 3 ? hold_plants<3>(n) : hold_plants<2>(n); }
	template<int N>
	uint64_t hold_plants(uint64_t n) {
		k37lag::Lag lags[N];
		for (int i = 0; i < N; i++) {
			const Axis &a = axis[i];
			lags[i] = lag(a, a.ctrl.dac);
			int64_t next = a.plant.ff ? Plant::command(a.in, a.ctrl.dac, a.plant.ff) : lags[i].vc;
			lags[i].hold(a.in.period, a.plant.phase, next);
		}
		bool crossed;
		uint64_t k = k37lag::advance_held(lags, size_t(N), n, crossed);
		for (int i = 0; i < N; i++)
			take(axis[i].plant, lags[i]);
		return k;
	}
	// run_plants with a torque or two-mass drive (drives.h).
	uint64_t advance_drives(uint64_t h) {
		Drive *plants[MAX_AXES];
		const PlantInputs *ins[MAX_AXES];
		uint64_t dacs[MAX_AXES];
		for (int i = 0; i < axes; i++) {
			plants[i] = &axis[i].plant;
			ins[i] = &axis[i].in;
			dacs[i] = axis[i].ctrl.dac;
		}
		return k37e::advance_drives(plants, ins, dacs, axes, h);
	}
	// Axis a's first-order plant as lag.h advances it, at D/A word `dac`.
	static k37lag::Lag lag(const Axis &a, uint64_t dac) {
		const Plant &p = a.plant;
		return k37lag::Lag(p.velocity, Plant::command(a.in, dac, 0), int64_t(a.in.alpha),
		                   p.before + uint64_t(p.velocity), a.in.stall, VC_BITS, ALPHA_BITS,
		                   FRAC_BITS);
	}
};

}  // namespace k37e
