// The K3701's curves at the step level, as their reference models state them
// (k37.hdl.k3701.datapaths.model.parabolic: ParabolicPath and ExponentialPath, drawn in the
// curve's own frame, FramePath): the next step (peek) and taking it (advance), for the
// interpolator of k3701.h, which times them as an arc's steps (the circular latency) after
// their setup cycles.

#pragma once

#include <cstdint>
#include <cstdlib>

#include "blocks.h"

namespace k37e {

// A parabola (F = A v - B p^2 - C p, by its function) or an exponential (a self-fed DDA) in
// the frame whose abscissa p (X, or Y with `swap`) runs from 0 to pe in the end's direction
// (su), the ordinate v the other axis.
struct CurvePath {
	bool exponential = false, swap = false;
	int su = 1, sv = 1, sk = 1;
	int64_t pe = 0, ve = 0, p = 0, v = 0, f = 0;
	int64_t a = 0, b = 0, g = 0;           // the parabola's
	int64_t k = 0, e = 0, q = 0, r2 = 0;   // the exponential's

	// The parabola through the start, (xe, ye) and the tangent point (i, j); false for data
	// the chip refuses (BlockError).
	bool init_parabola(int64_t xe, int64_t ye, int64_t i, int64_t j, bool swapped) {
		if (!frame(xe, ye, i, j, swapped))
			return false;
		int64_t vp = swapped ? i : j;
		a = pe * pe;
		b = 2 * ve - 4 * vp;
		g = b + pe * (4 * vp - ve);
		return true;
	}
	// The exponential to (xe, ye) of |k| = i (decaying with `flat`), offset j and E = frac.
	bool init_exponential(int64_t xe, int64_t ye, int64_t i, bool flat, int64_t j, int64_t frac,
	                      bool swapped) {
		if (!frame(xe, ye, i, j, swapped) || i < 2 || j < 0)
			return false;
		exponential = true;
		sv = ve < 0 ? -1 : 1;
		sk = flat ? -1 : 1;
		k = i;
		e = frac;
		q = j;
		return true;
	}
	bool frame(int64_t xe, int64_t ye, int64_t i, int64_t j, bool swapped) {
		for (int64_t c : {xe, ye, i, j})
			if (c < -COORD_MAX || c > COORD_MAX)
				return false;
		int64_t end_p = swapped ? ye : xe;
		if (end_p == 0)
			return false;
		*this = CurvePath();
		swap = swapped;
		su = end_p > 0 ? 1 : -1;
		pe = std::llabs(end_p);
		ve = swapped ? xe : ye;
		return true;
	}

	// The next step's moves in the frame (dp, dv: dv in the exponential's own direction,
	// times sv) and the F it leads to.
	void decide(int &dp, int &dv, int64_t &next_f) const {
		if (exponential) {
			if (std::llabs(q) <= k) {
				int64_t d1 = f + q, d2 = f + q - k;
				bool both = std::llabs(d2) < std::llabs(d1);
				dp = 1, dv = both, next_f = both ? d2 : d1;
				return;
			}
			int64_t d1 = f - k, d2 = f + q - k;  // |d2| < |d1| as the chip tests it
			bool both = d1 + d2 < 0;
			dp = both, dv = 1, next_f = both ? d2 : d1;
			return;
		}
		int s = g > 0 ? 1 : -1;
		if (std::llabs(g) <= a) {
			int64_t d1 = f - g, d2 = d1 + a * s;
			bool both = std::llabs(d2) < std::llabs(d1);
			dp = 1, dv = both ? s : 0, next_f = both ? d2 : d1;
			return;
		}
		int64_t d1 = f + a * s, d2 = d1 - g;
		bool both = std::llabs(d2) < std::llabs(d1);
		dp = both, dv = s, next_f = both ? d2 : d1;
	}
	// A step's moves in the block's X and Y.
	void step(int dp, int dv, int &dx, int &dy) const {
		int du = su * dp, w = exponential ? sv * dv : dv;
		dx = swap ? w : du;
		dy = swap ? du : w;
	}
	// The next step (the path must not be done).
	void peek(int &dx, int &dy) const {
		int dp, dv;
		int64_t unused;
		decide(dp, dv, unused);
		step(dp, dv, dx, dy);
	}
	// Take the next step: its moves, whether it ends the block and whether with an error.
	void advance(int &dx, int &dy, bool &final, bool &error) {
		int dp, dv;
		int64_t sr = e - f;  // the exponential's -sign(k) R before the step
		decide(dp, dv, f);
		if (exponential) {
			if (dp)
				r2 = wrap(r2 + sr, unsigned(EXPONENTIAL_R2_BITS));
			for (int n = 0; n < 2; n++) {
				int carry = r2 >= k ? 1 : r2 < 0 ? -1 : 0;
				r2 -= carry * k;
				f -= sk * carry;
			}
			q += sk * dv;
		} else if (dp) {
			g += 2 * b;
		}
		p += dp;
		v += exponential ? sv * dv : dv;
		error = p > pe || (exponential && sv * v > std::llabs(ve));
		final = error || (p == pe && v == ve);
		step(dp, dv, dx, dy);
	}
};

}  // namespace k37e
