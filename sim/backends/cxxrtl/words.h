// CXXRTL's arithmetic on values of at most 128 bits, in machine words.
//
// CXXRTL computes on 32-bit chunks in loops (an addition carries from chunk to chunk, a
// product sums partial products); on a value that fits a machine word (64 bits, or 128 with
// GCC's __int128) the same op is one instruction or a few. Each op here is the same modular
// (add, sub, mul, neg: mod 2^Y of operands extended to a common word) or ordered (compare:
// of operands zero- or sign-extended to the wider's width) arithmetic as CXXRTL's; wider
// values fall back to CXXRTL's own. The design's translation unit includes this before the
// design, whose calls the macros at the end rename (the runtime itself is compiled first,
// untouched). tests/sim/backends/test_cxxrtl.py compares every op with CXXRTL's over random
// operands.
#include <cxxrtl/cxxrtl.h>

namespace cxxrtl_yosys {

using k37_u128 = unsigned __int128;
using k37_i128 = __int128;

// A machine word of at least N bits.
template<size_t N>
using k37_word = typename std::conditional<(N <= 64), uint64_t, k37_u128>::type;

// v zero-extended to a word of at least W >= N bits.
template<size_t W, size_t N>
CXXRTL_ALWAYS_INLINE k37_word<W> k37_zx(const value<N> &v) {
	k37_word<W> r = v.data[0];
	for (size_t i = 1; i < value<N>::chunks; i++)
		r |= k37_word<W>(v.data[i]) << (32 * i);
	return r;
}

// v sign-extended to a word of at least W >= N bits.
template<size_t W, size_t N>
CXXRTL_ALWAYS_INLINE k37_word<W> k37_sx(const value<N> &v) {
	constexpr size_t bits = sizeof(k37_word<W>) * 8;
	k37_word<W> r = k37_zx<W>(v);
	if (N < bits)
		r = (r ^ (k37_word<W>(1) << (N - 1))) - (k37_word<W>(1) << (N - 1));
	return r;
}

// The low N bits of word r.
template<size_t N, class T>
CXXRTL_ALWAYS_INLINE value<N> k37_value(T r) {
	value<N> v;
	for (size_t i = 0; i < value<N>::chunks; i++)
		v.data[i] = chunk_t(r >> (32 * i));
	v.data[value<N>::chunks - 1] &= value<N>::msb_mask;
	return v;
}

// Whether an op of these widths runs in machine words (of the widest's width).
template<size_t Y, size_t A, size_t B = 1>
constexpr bool k37_fast = Y >= 1 && A >= 1 && B >= 1 && Y <= 128 && A <= 128 && B <= 128;

#define K37_BINARY(name, ext, expr)                                                         \
template<size_t Y, size_t A, size_t B>                                                      \
CXXRTL_ALWAYS_INLINE value<Y> k37_##name(const value<A> &a, const value<B> &b) {            \
	if constexpr (k37_fast<Y, A, B>) {                                                      \
		constexpr size_t W = Y > A ? (Y > B ? Y : B) : (A > B ? A : B);                     \
		auto x = k37_##ext<W>(a), y = k37_##ext<W>(b);                                      \
		return k37_value<Y>(expr);                                                          \
	} else {                                                                                \
		return name<Y>(a, b);                                                               \
	}                                                                                       \
}
K37_BINARY(add_uu, zx, x + y)
K37_BINARY(add_ss, sx, x + y)
K37_BINARY(sub_uu, zx, x - y)
K37_BINARY(sub_ss, sx, x - y)
K37_BINARY(mul_uu, zx, x * y)
K37_BINARY(mul_ss, sx, x * y)
#undef K37_BINARY

#define K37_COMPARE(name, ext, signed_type, op)                                             \
template<size_t Y, size_t A, size_t B>                                                      \
CXXRTL_ALWAYS_INLINE value<Y> k37_##name(const value<A> &a, const value<B> &b) {            \
	if constexpr (k37_fast<Y, A, B>) {                                                      \
		constexpr size_t W = A > B ? A : B;                                                 \
		using S = typename std::conditional<(W <= 64), int64_t, k37_i128>::type;            \
		auto x = k37_##ext<W>(a), y = k37_##ext<W>(b);                                      \
		return value<Y>{(signed_type(x) op signed_type(y)) ? 1u : 0u};                      \
	} else {                                                                                \
		return name<Y>(a, b);                                                               \
	}                                                                                       \
}
K37_COMPARE(lt_uu, zx, , <)
K37_COMPARE(gt_uu, zx, , >)
K37_COMPARE(le_uu, zx, , <=)
K37_COMPARE(ge_uu, zx, , >=)
K37_COMPARE(lt_ss, sx, S, <)
K37_COMPARE(gt_ss, sx, S, >)
K37_COMPARE(le_ss, sx, S, <=)
K37_COMPARE(ge_ss, sx, S, >=)
#undef K37_COMPARE

#define K37_NEGATE(name, ext)                                                               \
template<size_t Y, size_t A>                                                                \
CXXRTL_ALWAYS_INLINE value<Y> k37_##name(const value<A> &a) {                               \
	if constexpr (k37_fast<Y, A>)                                                           \
		return k37_value<Y>(-k37_##ext<(Y > A ? Y : A)>(a));                                \
	else                                                                                    \
		return name<Y>(a);                                                                  \
}
K37_NEGATE(neg_u, zx)
K37_NEGATE(neg_s, sx)
#undef K37_NEGATE

}  // namespace cxxrtl_yosys

#define add_uu k37_add_uu
#define add_ss k37_add_ss
#define sub_uu k37_sub_uu
#define sub_ss k37_sub_ss
#define mul_uu k37_mul_uu
#define mul_ss k37_mul_ss
#define lt_uu k37_lt_uu
#define gt_uu k37_gt_uu
#define le_uu k37_le_uu
#define ge_uu k37_ge_uu
#define lt_ss k37_lt_ss
#define gt_ss k37_gt_ss
#define le_ss k37_le_ss
#define ge_ss k37_ge_ss
#define neg_u k37_neg_u
#define neg_s k37_neg_s
