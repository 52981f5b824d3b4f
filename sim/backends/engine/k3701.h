// The KM3701 interpolator, two- or three-axis, at its ports, cycle by cycle, as its reference
// model states it (k37.hdl.k3701.model.chip.K3701Model, with the paths of
// k37.hdl.k3701.datapaths.model: linear, circular and helix): BUSY, the radius
// check's setup cycles, the FP credit (half-FP units, quarter-FP on three axes), the one-FP
// hold and the overrun bit, the step latency count, the step pulses routed by CTRL.plane. Lines,
// arcs, helices, and the parabolas and exponentials of curves.h.

#pragma once

#include <cstdint>
#include <cstdlib>

#include "blocks.h"
#include "curves.h"

namespace k37e {

enum class Kind { LINEAR, CIRCULAR, PARABOLIC, EXPONENTIAL };

// A step in the block's axes.
struct Move {
	int dx = 0, dy = 0, dz = 0;
	int moved() const { return (dx != 0) + (dy != 0) + (dz != 0); }
};

// One short axis of a DDA (Dda).
struct Dda {
	int64_t n = 0, total = 0, acc = 0;
	bool peek() const { return acc + n >= total; }
	bool advance() {
		bool move = peek();
		acc += n - (move ? total : 0);
		return move;
	}
};

// A line by DDA long-axis stepping (LinearPath): the long axis the largest |component|
// (ties to the first), each other axis a DDA over the long count.
struct LinePath {
	int long_axis = 0, sign[3] = {};
	int64_t left = 0;
	Dda dda[3];

	void init(const int64_t (&end)[3]) {
		int64_t mag[3];
		for (int k = 0; k < 3; k++) {
			mag[k] = std::llabs(end[k]);
			sign[k] = (end[k] > 0) - (end[k] < 0);
		}
		long_axis = 0;
		for (int k = 1; k < 3; k++)
			if (mag[k] > mag[long_axis])
				long_axis = k;
		left = mag[long_axis];
		for (int k = 0; k < 3; k++)
			dda[k] = {mag[k], left, left / 2};
	}
	Move make(const bool (&moves)[3]) const {
		int d[3];
		for (int k = 0; k < 3; k++)
			d[k] = k == long_axis || moves[k] ? sign[k] : 0;
		return {d[0], d[1], d[2]};
	}
	Move peek() const {
		bool moves[3];
		for (int k = 0; k < 3; k++)
			moves[k] = k != long_axis && dda[k].peek();
		return make(moves);
	}
	Move advance(bool &final) {
		bool moves[3];
		for (int k = 0; k < 3; k++)
			moves[k] = k != long_axis && dda[k].advance();
		final = --left == 0;
		return make(moves);
	}
};

// A helix's third axis: ze moves spread over the arc's n steps (HelixPath; |ze| <= n).
struct HelixPath {
	int sign = 0;
	Dda dda;
	bool init(int64_t ze, int64_t n) {
		if (ze < -COORD_MAX || ze > COORD_MAX || std::llabs(ze) > n)
			return false;
		sign = (ze > 0) - (ze < 0);
		dda = {std::llabs(ze), n, n / 2};
		return true;
	}
	int peek() const { return dda.peek() ? sign : 0; }
	int advance() { return dda.advance() ? sign : 0; }
};

// Motion signs inside each quadrant (QUADRANT_SIGNS), [cw][quadrant - 1].
constexpr int QUADRANT_SX[2][4] = {{-1, -1, 1, 1}, {1, 1, -1, -1}};
constexpr int QUADRANT_SY[2][4] = {{1, -1, -1, 1}, {-1, 1, 1, -1}};

// quadrant_of (the point is not the centre).
inline int quadrant_of(int64_t x, int64_t y, bool cw) {
	if (!cw) {
		if (x > 0 && y >= 0) return 1;
		if (x <= 0 && y > 0) return 2;
		if (x < 0 && y <= 0) return 3;
		return 4;
	}
	if (x >= 0 && y > 0) return 1;
	if (x < 0 && y >= 0) return 2;
	if (x <= 0 && y < 0) return 3;
	return 4;
}

// An arc by sign-of-F stepping (CircularPath).
struct ArcPath {
	bool cw = false, armed = false, end_on_x = false;
	int64_t x = 0, y = 0, ex = 0, ey = 0, d = 0;
	int q = 1, end_q = 1;

	static bool coord_ok(int64_t v) { return v >= -COORD_MAX && v <= COORD_MAX; }
	// False for data the chip refuses (BlockError).
	bool init(int64_t xe, int64_t ye, int64_t i, int64_t j, bool clockwise, int quadrant) {
		if (!coord_ok(xe) || !coord_ok(ye) || !coord_ok(i) || !coord_ok(j))
			return false;
		if ((i == 0 && j == 0) || i * i + j * j > MAX_RADIUS_SQUARED)
			return false;
		cw = clockwise;
		x = -i;
		y = -j;
		ex = xe - i;
		ey = ye - j;
		if (ex == 0 && ey == 0)
			return false;
		if (quadrant_of(ex, ey, cw) != quadrant)
			return false;
		d = 0;
		q = quadrant_of(x, y, cw);
		end_q = quadrant;
		end_on_x = std::llabs(ey) >= std::llabs(ex);
		armed = q == end_q && ahead();
		return true;
	}
	bool ahead() const {
		int s = end_on_x ? QUADRANT_SX[cw][q - 1] : QUADRANT_SY[cw][q - 1];
		return end_on_x ? (ex - x) * s > 0 : (ey - y) * s > 0;
	}
	Move decide(int64_t &next_d) const {
		int sx = QUADRANT_SX[cw][q - 1], sy = QUADRANT_SY[cw][q - 1];
		if (std::llabs(y) >= std::llabs(x)) {
			int64_t d1 = d + 2 * x * sx + 1, d2 = d1 + 2 * y * sy + 1;
			if (std::llabs(d2) < std::llabs(d1)) {
				next_d = d2;
				return {sx, sy};
			}
			next_d = d1;
			return {sx, 0};
		}
		int64_t d1 = d + 2 * y * sy + 1, d2 = d1 + 2 * x * sx + 1;
		if (std::llabs(d2) < std::llabs(d1)) {
			next_d = d2;
			return {sx, sy};
		}
		next_d = d1;
		return {0, sy};
	}
	Move peek() const {
		int64_t unused;
		return decide(unused);
	}
	Move advance(bool &final, bool &error) {
		Move m = decide(d);
		x += m.dx;
		y += m.dy;
		int nq = quadrant_of(x, y, cw);
		if (!armed && nq == end_q && nq != q)
			armed = true;
		q = nq;
		final = error = false;
		if (armed) {
			if (q != end_q)
				final = error = true;
			else if (end_on_x ? x == ex : y == ey)
				final = true;
		}
		return m;
	}
};

// The chip's registered outputs: the step pulses by machine axis (+1, 0, -1), the status bits
// and the remaining distances in the block's axes.
struct K3701Out {
	int step[3] = {};
	bool busy = false, irq = false, error = false, overrun = false;
	int64_t xm = 0, ym = 0, zm = 0;
};

struct K3701 {
	enum class Phase { IDLE, SETUP, RUN };
	int axes = 2;
	Bank bank;
	K3701Out out;
	Phase phase = Phase::IDLE;
	Kind kind = Kind::LINEAR;
	bool sqrt2 = false, held = false;
	int64_t setup_left = 0, count = 0, credit = 0;
	int64_t xe = 0, ye = 0, ze = 0, i = 0, j = 0, e = 0, helix_steps = 0;
	bool cw = false, swap = false;
	int quadrant = 1, plane = 0;
	LinePath line;
	ArcPath arc;
	HelixPath helix;  // an arc's third axis (ze != 0)
	CurvePath curve;  // a parabola or an exponential
	bool curve_kind() const { return kind == Kind::PARABOLIC || kind == Kind::EXPONENTIAL; }

	void init(int chip_axes) {
		axes = chip_axes;
		if (axes == 3)
			bank.init(K3701_3_REGS, K3701_3_REG_COUNT);
		else
			bank.init(K3701_REGS, K3701_REG_COUNT);
	}
	// A step's cost in credit units, and what an FP adds.
	int64_t cost(const Move &m) const { return STEP_COST[axes - 2][sqrt2][m.moved() - 1]; }
	int64_t unit() const { return STEP_COST[axes - 2][0][0]; }
	Move peek() const {
		if (kind == Kind::LINEAR)
			return line.peek();
		if (curve_kind()) {
			Move m;
			curve.peek(m.dx, m.dy);
			return m;
		}
		Move m = arc.peek();
		m.dz = ze ? helix.peek() : 0;
		return m;
	}
	Move advance(bool &final, bool &error) {
		error = false;
		if (kind == Kind::LINEAR)
			return line.advance(final);
		if (curve_kind()) {
			Move m;
			curve.advance(m.dx, m.dy, final, error);
			return m;
		}
		Move m = arc.advance(final, error);
		m.dz = ze ? helix.advance() : 0;
		return m;
	}

	int latency() const { return kind == Kind::LINEAR ? LATENCY_LINEAR : LATENCY_CIRCULAR; }
	// The simulation-only `quiet` of the chip (k37.hdl.k3701.core): no FP, and the latency
	// count waiting or past the running datapath's decision stages.
	bool quiet(bool fp) const {
		int64_t stages = kind == Kind::LINEAR ? (axes == 3 ? LINEAR3_STAGES : LINEAR_STAGES)
		                 : curve_kind()       ? CURVE_STAGES
		                                      : (axes == 3 ? CIRCULAR3_STAGES : CIRCULAR_STAGES);
		bool past = stages == 0 || count <= latency() - 1 - stages;
		return !fp && (count == 0 || (count >= 2 && past));
	}
	bool cmd(unsigned field) const { return bank.stb(K3701_CMD) && bit(bank.value[K3701_CMD], field); }
	uint64_t read(int reg) const {
		switch (reg) {
		case K3701_X: return uint64_t(out.xm) & low_bits(24);
		case K3701_Y: return uint64_t(out.ym) & low_bits(24);
		case K3701_3_Z: return axes == 3 ? uint64_t(out.zm) & low_bits(24) : 0;
		case K3701_3_MODE: return bank.value[K3701_3_MODE];
		case K3701_CTRL: return bank.value[K3701_CTRL];
		case K3701_STATUS:
			return uint64_t(out.busy) << K3701_STATUS_BUSY | uint64_t(out.irq) << K3701_STATUS_IRQ |
			       uint64_t(out.error) << K3701_STATUS_ERROR | uint64_t(out.overrun) << K3701_STATUS_OVERRUN;
		default: return 0;
		}
	}
	// One cycle (the rising edge that ends it) with this cycle's FP (K3701Model.cycle). The
	// outputs are registers updated in place: each update reads only the chip's state.
	void rise(bool fp) {
		out.step[0] = out.step[1] = out.step[2] = 0;
		bool strobe = bank.stb(K3701_CMD);
		if (strobe) {
			out.irq = out.irq && !cmd(K3701_CMD_ACK);
			if (cmd(K3701_CMD_CLEAR))
				out.error = out.overrun = false;
		}
		bool was_idle = phase == Phase::IDLE;
		if (phase == Phase::SETUP) {
			if (fp)
				hold();
			if (--setup_left == 0) {
				if (curve_kind() ? init_curve()
				                 : arc.init(xe, ye, i, j, cw, quadrant) &&
				                       (ze == 0 || helix.init(ze, helix_steps)))
					phase = Phase::RUN;
				else
					finish(true);
			}
		} else if (phase == Phase::RUN) {
			run(fp);
		}
		if (strobe && cmd(K3701_CMD_START)) {
			if (!was_idle)
				out.error = true;
			else
				start();
		}
	}
	// At the end of a curve's setup: its path, or false for data the chip refuses (and for a
	// curve with a third coordinate, on three axes).
	bool init_curve() {
		if (ze != 0)
			return false;
		return kind == Kind::PARABOLIC ? curve.init_parabola(xe, ye, i, j, swap)
		                               : curve.init_exponential(xe, ye, i, cw, j, e, swap);
	}
	void hold() {
		if (held)
			out.overrun = true;
		else
			held = true;
	}
	void finish(bool error) {
		phase = Phase::IDLE;
		held = false;
		count = 0;
		out.busy = false;
		out.irq = true;
		out.error = out.error || error;
	}
	void start() {
		uint64_t word = bank.value[K3701_CTRL];
		uint64_t modes = axes == 3 ? bank.value[K3701_3_MODE] : word;
		unsigned parabolic = axes == 3 ? K3701_3_MODE_PARABOLIC : K3701_CTRL_PARABOLIC;
		unsigned exponential = axes == 3 ? K3701_3_MODE_EXPONENTIAL : K3701_CTRL_EXPONENTIAL;
		kind = bit(modes, exponential) ? Kind::EXPONENTIAL
		       : bit(modes, parabolic) ? Kind::PARABOLIC
		       : bit(word, K3701_CTRL_CIRCULAR) ? Kind::CIRCULAR : Kind::LINEAR;
		xe = bank.get(K3701_X);
		ye = bank.get(K3701_Y);
		ze = axes == 3 ? bank.get(K3701_3_Z) : 0;
		helix_steps = axes == 3 ? bank.get(K3701_3_H) : 0;
		plane = axes == 3 ? int(word >> K3701_3_CTRL_PLANE & low_bits(K3701_3_CTRL_PLANE_WIDTH)) : 0;
		i = bank.get(K3701_I);
		j = bank.get(K3701_J);
		cw = bit(word, K3701_CTRL_CW);
		sqrt2 = bit(word, K3701_CTRL_SQRT2);
		quadrant = int(word >> K3701_CTRL_QUADRANT & low_bits(K3701_CTRL_QUADRANT_WIDTH)) + 1;
		credit = 0;
		held = false;
		count = 0;
		out.xm = xe;
		out.ym = ye;
		out.zm = ze;
		swap = bit(modes, axes == 3 ? K3701_3_MODE_SWAP : K3701_CTRL_SWAP);
		e = bank.get(axes == 3 ? int(K3701_3_E) : int(K3701_E));
		if (kind != Kind::LINEAR) {
			phase = Phase::SETUP;
			setup_left = kind == Kind::CIRCULAR   ? CIRCLE_SETUP_CYCLES
			             : kind == Kind::PARABOLIC ? PARABOLA_SETUP_CYCLES
			                                       : EXPONENTIAL_SETUP_CYCLES;
			out.busy = true;
			return;
		}
		if (!ArcPath::coord_ok(xe) || !ArcPath::coord_ok(ye) || !ArcPath::coord_ok(ze)) {
			out.irq = out.error = true;
			return;
		}
		line.init({xe, ye, ze});
		if (line.left == 0) {
			out.irq = true;
			return;
		}
		phase = Phase::RUN;
		out.busy = true;
	}
	void run(bool fp) {
		if (count) {
			if (fp)
				hold();
			if (--count == 0) {
				bool final = false, error = false;
				Move m = advance(final, error);
				const int *to = PLANES[plane < 3 ? plane : 0];  // the machine axis of each
				out.step[to[0]] = m.dx;
				out.step[to[1]] = m.dy;
				out.step[to[2]] = m.dz;
				out.xm -= m.dx;
				out.ym -= m.dy;
				out.zm -= m.dz;
				if (final)
					finish(error);
			}
			return;
		}
		bool take = held || fp;
		if (held)
			held = fp;
		if (take) {
			credit += unit();
			int64_t need = cost(peek());
			if (credit >= need) {
				credit -= need;
				count = latency() - 1;
			}
		}
	}
};

}  // namespace k37e
