//! The number types shading is written over, so that one source runs one path at a time or
//! eight: [`Real`] with its [`Mask`] and [`Bits`], implemented by `f32` (one lane, `bool`,
//! `u32`) and by [`F8`] (eight lanes, [`M8`], [`U8`]), and the 2- and 3-vectors [`Vec2L`] and
//! [`Vec3L`] of either.
//!
//! **Same bits at every width.** Every operation of the trait is one IEEE 754 operation per
//! lane (add, subtract, multiply, divide, square root, compare, select, bit operations,
//! conversions), so lane *i* of an eight-wide computation is bit for bit the one-lane
//! computation of lane *i*'s inputs. What would break that is left out on purpose:
//! - no fused multiply-add: AVX2 fuses in one rounding, the baseline x86-64 build (no FMA)
//!   would call libm's `fmaf` per lane; `a * b + c` rounds twice at every width;
//! - no approximate reciprocals (`rcpps`, `rsqrtps`), whose bits differ between processors;
//! - `min`/`max` are defined by a comparison and a select (`if a < b { a } else { b }`), not
//!   by `f32::min` (which drops a NaN) or `minps` (which returns the second operand);
//! - the transcendental functions are [`crate::math`]'s polynomials over this trait, not
//!   libm's, whose results differ between its scalar and vector forms.
//!
//! **How eight lanes become AVX2.** [`F8`] is a plain `[f32; 8]` whose operators are loops
//! over the lanes, always inlined. Compiled inside [`dispatch`], which enters a function
//! with AVX2 and FMA enabled when the processor has them (chosen at run time by `pulp`,
//! which keeps the `unsafe` of `#[target_feature]` inside itself), LLVM turns each loop into
//! one 256-bit instruction; elsewhere, or on a processor without AVX2, the same loops become
//! pairs of SSE instructions, with the same bits. `wide`'s `f32x8` was not chosen: it picks
//! its instructions by the *compile-time* target features, so the baseline binary would run
//! SSE pairs even inside an AVX2 function; hand-written `std::arch` would need `unsafe`
//! outside the FFI modules; `std::simd` is not stable.

use std::fmt::Debug;
use std::ops::{
    Add, AddAssign, BitAnd, BitOr, BitXor, Div, DivAssign, Mul, MulAssign, Neg, Not, Sub, SubAssign,
};

/// The lanes' booleans: `bool` for one lane, [`M8`] for eight.
pub trait Mask:
    Copy
    + Debug
    + PartialEq
    + Send
    + Sync
    + 'static
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
    + BitXor<Output = Self>
    + Not<Output = Self>
{
    /// Every lane `b`.
    fn splat(b: bool) -> Self;
    /// Lane `i` from `f(i)`.
    fn from_fn(f: impl FnMut(usize) -> bool) -> Self;
    /// Lane `i`.
    fn lane(self, i: usize) -> bool;
    /// True when some lane is true.
    fn any(self) -> bool;
    /// True when every lane is true.
    fn all(self) -> bool;
    /// True when no lane is true.
    #[inline(always)]
    fn none(self) -> bool {
        !self.any()
    }
}

/// The lanes' 32-bit words (the bits of a float, an index, a hash): `u32` or [`U8`]. The
/// arithmetic wraps at every width.
pub trait Bits:
    Copy
    + Debug
    + PartialEq
    + Send
    + Sync
    + 'static
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
    + BitXor<Output = Self>
    + Not<Output = Self>
{
    type Mask: Mask;
    /// How many lanes one value carries.
    const LANES: usize;
    /// Every lane `x`.
    fn splat(x: u32) -> Self;
    /// Lane `i` from `f(i)`.
    fn from_fn(f: impl FnMut(usize) -> u32) -> Self;
    /// Lane `i`.
    fn lane(self, i: usize) -> u32;
    fn wrapping_add(self, o: Self) -> Self;
    fn wrapping_sub(self, o: Self) -> Self;
    fn wrapping_mul(self, o: Self) -> Self;
    /// Each lane shifted left by `n` < 32.
    fn shl(self, n: u32) -> Self;
    /// Each lane shifted right (logically) by `n` < 32.
    fn shr(self, n: u32) -> Self;
    fn eq(self, o: Self) -> Self::Mask;
    /// Unsigned less-than.
    fn lt(self, o: Self) -> Self::Mask;
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// Each lane's bits in reverse order.
    fn reverse_bits(self) -> Self;
    /// `table[index % N]` per lane: the modulo (a mask for the power-of-two sizes tables
    /// have) spares each lane a bounds check and its branch; an index ≥ N is a bug that
    /// debug builds catch.
    fn gather<const N: usize>(table: &[u32; N], index: Self) -> Self;
    /// The four words of `table[index % N]` per lane, one load of 16 bytes per lane.
    fn gather4<const N: usize>(table: &[[u32; 4]; N], index: Self) -> [Self; 4];
    /// `table[index]` per lane, from a table of any length; an index out of range panics.
    fn gather_slice(table: &[u32], index: Self) -> Self;
}

/// Each byte value with its bits in reverse order.
const REVERSED_BYTE: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut b = 0;
    while b < 256 {
        t[b] = (b as u8).reverse_bits();
        b += 1;
    }
    t
};

/// A float of one lane or several: what the lobes, warps, samplers and lookups are written
/// over (see the module documentation for why every width gives the same bits).
pub trait Real:
    Copy
    + Debug
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f32, Output = Self>
    + Sub<f32, Output = Self>
    + Mul<f32, Output = Self>
    + Div<f32, Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
{
    type Mask: Mask;
    type Bits: Bits<Mask = Self::Mask>;
    /// How many paths one value carries.
    const LANES: usize;
    const ZERO: Self;
    const ONE: Self;

    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// Lane `i` from `f(i)`.
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self;
    /// Lane `i`.
    fn lane(self, i: usize) -> f32;

    /// `a` where `m` is true, `b` elsewhere.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    fn lt(self, o: Self) -> Self::Mask;
    fn le(self, o: Self) -> Self::Mask;
    fn gt(self, o: Self) -> Self::Mask;
    fn ge(self, o: Self) -> Self::Mask;
    fn eq(self, o: Self) -> Self::Mask;
    fn ne(self, o: Self) -> Self::Mask;

    /// The correctly rounded square root.
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    /// The largest integer not above each lane.
    fn floor(self) -> Self;
    /// The bits of each lane.
    fn to_bits(self) -> Self::Bits;
    fn from_bits(b: Self::Bits) -> Self;
    /// Each lane rounded toward zero to an `i32` (saturating, NaN to 0, as `as i32`), its
    /// two's-complement bits.
    fn trunc_i32(self) -> Self::Bits;
    /// Each lane's bits read as an `i32`, converted to the nearest float.
    fn from_i32(b: Self::Bits) -> Self;
    /// `table[index % N]` per lane, as [`Bits::gather`].
    fn gather<const N: usize>(table: &[f32; N], index: Self::Bits) -> Self;
    /// The four floats of `table[index]` per lane (a texel, say), one load of 16 bytes per
    /// lane; an index out of range panics.
    fn gather4(table: &[[f32; 4]], index: Self::Bits) -> [Self; 4];
    /// `table[index]` per lane, from a table of any length; an index out of range panics.
    fn gather_slice(table: &[f32], index: Self::Bits) -> Self;

    /// `self` where `self < o`, else `o`.
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Self::select(self.lt(o), self, o)
    }
    /// `self` where `self > o`, else `o`.
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Self::select(self.gt(o), self, o)
    }
    /// `self.max(lo).min(hi)`.
    #[inline(always)]
    fn clamp(self, lo: Self, hi: Self) -> Self {
        self.max(lo).min(hi)
    }
    /// The magnitude of `self` with the sign bit of `sign`.
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        let m = Self::Bits::splat(0x8000_0000);
        Self::from_bits((self.to_bits() & !m) | (sign.to_bits() & m))
    }
    /// `1 / self`, correctly rounded.
    #[inline(always)]
    fn recip(self) -> Self {
        Self::ONE / self
    }
    /// The square, `self * self`.
    #[inline(always)]
    fn sqr(self) -> Self {
        self * self
    }
    /// `√max(self, 0)`: a radicand that rounding took a little below zero gives 0, not NaN.
    #[inline(always)]
    fn safe_sqrt(self) -> Self {
        self.max(Self::ZERO).sqrt()
    }
}

impl Mask for bool {
    #[inline(always)]
    fn splat(b: bool) -> bool {
        b
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> bool) -> bool {
        f(0)
    }
    #[inline(always)]
    fn lane(self, _i: usize) -> bool {
        self
    }
    #[inline(always)]
    fn any(self) -> bool {
        self
    }
    #[inline(always)]
    fn all(self) -> bool {
        self
    }
}

impl Bits for u32 {
    type Mask = bool;
    const LANES: usize = 1;
    #[inline(always)]
    fn splat(x: u32) -> u32 {
        x
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> u32) -> u32 {
        f(0)
    }
    #[inline(always)]
    fn lane(self, _i: usize) -> u32 {
        self
    }
    #[inline(always)]
    fn wrapping_add(self, o: u32) -> u32 {
        u32::wrapping_add(self, o)
    }
    #[inline(always)]
    fn wrapping_sub(self, o: u32) -> u32 {
        u32::wrapping_sub(self, o)
    }
    #[inline(always)]
    fn wrapping_mul(self, o: u32) -> u32 {
        u32::wrapping_mul(self, o)
    }
    #[inline(always)]
    fn shl(self, n: u32) -> u32 {
        self << n
    }
    #[inline(always)]
    fn shr(self, n: u32) -> u32 {
        self >> n
    }
    #[inline(always)]
    fn eq(self, o: u32) -> bool {
        self == o
    }
    #[inline(always)]
    fn lt(self, o: u32) -> bool {
        self < o
    }
    #[inline(always)]
    fn select(m: bool, a: u32, b: u32) -> u32 {
        if m {
            a
        } else {
            b
        }
    }
    /// By byte lookups: x86-64 has no bit-reversal instruction, and four loads cost less
    /// than the dozen shifts and masks of `u32::reverse_bits` (which eight lanes use, as
    /// AVX2 reverses bytes with one shuffle).
    #[inline(always)]
    fn reverse_bits(self) -> u32 {
        let r = |k: u32| REVERSED_BYTE[((self >> (8 * k)) & 0xff) as usize] as u32;
        (r(0) << 24) | (r(1) << 16) | (r(2) << 8) | r(3)
    }
    #[inline(always)]
    fn gather<const N: usize>(table: &[u32; N], index: u32) -> u32 {
        debug_assert!((index as usize) < N);
        table[index as usize % N]
    }
    #[inline(always)]
    fn gather4<const N: usize>(table: &[[u32; 4]; N], index: u32) -> [u32; 4] {
        debug_assert!((index as usize) < N);
        table[index as usize % N]
    }
    #[inline(always)]
    fn gather_slice(table: &[u32], index: u32) -> u32 {
        table[index as usize]
    }
}

impl Real for f32 {
    type Mask = bool;
    type Bits = u32;
    const LANES: usize = 1;
    const ZERO: f32 = 0.0;
    const ONE: f32 = 1.0;

    #[inline(always)]
    fn splat(x: f32) -> f32 {
        x
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> f32 {
        f(0)
    }
    #[inline(always)]
    fn lane(self, _i: usize) -> f32 {
        self
    }
    #[inline(always)]
    fn select(m: bool, a: f32, b: f32) -> f32 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn lt(self, o: f32) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: f32) -> bool {
        self <= o
    }
    #[inline(always)]
    fn gt(self, o: f32) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: f32) -> bool {
        self >= o
    }
    #[inline(always)]
    fn eq(self, o: f32) -> bool {
        self == o
    }
    #[inline(always)]
    fn ne(self, o: f32) -> bool {
        self != o
    }
    #[inline(always)]
    fn sqrt(self) -> f32 {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> f32 {
        f32::abs(self)
    }
    #[inline(always)]
    fn floor(self) -> f32 {
        f32::floor(self)
    }
    #[inline(always)]
    fn to_bits(self) -> u32 {
        f32::to_bits(self)
    }
    #[inline(always)]
    fn from_bits(b: u32) -> f32 {
        f32::from_bits(b)
    }
    #[inline(always)]
    fn trunc_i32(self) -> u32 {
        self as i32 as u32
    }
    #[inline(always)]
    fn from_i32(b: u32) -> f32 {
        b as i32 as f32
    }
    #[inline(always)]
    fn gather<const N: usize>(table: &[f32; N], index: u32) -> f32 {
        debug_assert!((index as usize) < N);
        table[index as usize % N]
    }
    #[inline(always)]
    fn gather4(table: &[[f32; 4]], index: u32) -> [f32; 4] {
        table[index as usize]
    }
    #[inline(always)]
    fn gather_slice(table: &[f32], index: u32) -> f32 {
        table[index as usize]
    }
}

/// Eight floats, one per path (see the module documentation for how they become AVX2).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct F8(pub [f32; 8]);

/// Eight lanes' booleans, each all ones (true) or all zeros.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C, align(32))]
pub struct M8(pub [u32; 8]);

/// Eight 32-bit words.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C, align(32))]
pub struct U8(pub [u32; 8]);

/// Lane-wise operators of an eight-lane type over its array.
macro_rules! lanewise {
    ($t:ident, $lane:ty, $($trait:ident $method:ident $op:tt),*) => {$(
        impl $trait for $t {
            type Output = $t;
            #[inline(always)]
            fn $method(self, o: $t) -> $t {
                $t(std::array::from_fn(|i| self.0[i] $op o.0[i]))
            }
        }
    )*};
}
lanewise!(F8, f32, Add add +, Sub sub -, Mul mul *, Div div /);
lanewise!(M8, u32, BitAnd bitand &, BitOr bitor |, BitXor bitxor ^);
lanewise!(U8, u32, BitAnd bitand &, BitOr bitor |, BitXor bitxor ^);

/// `F8 op f32` as `F8 op splat(f32)`, and the assigning forms.
macro_rules! scalar_ops {
    ($($trait:ident $method:ident $assign:ident $assign_method:ident $op:tt),*) => {$(
        impl $trait<f32> for F8 {
            type Output = F8;
            #[inline(always)]
            fn $method(self, o: f32) -> F8 {
                self $op F8([o; 8])
            }
        }
        impl $assign for F8 {
            #[inline(always)]
            fn $assign_method(&mut self, o: F8) {
                *self = *self $op o;
            }
        }
    )*};
}
scalar_ops!(
    Add add AddAssign add_assign +,
    Sub sub SubAssign sub_assign -,
    Mul mul MulAssign mul_assign *,
    Div div DivAssign div_assign /
);

impl Neg for F8 {
    type Output = F8;
    #[inline(always)]
    fn neg(self) -> F8 {
        F8(self.0.map(|x| -x))
    }
}

impl Not for M8 {
    type Output = M8;
    #[inline(always)]
    fn not(self) -> M8 {
        M8(self.0.map(|x| !x))
    }
}

impl Not for U8 {
    type Output = U8;
    #[inline(always)]
    fn not(self) -> U8 {
        U8(self.0.map(|x| !x))
    }
}

impl Mask for M8 {
    #[inline(always)]
    fn splat(b: bool) -> M8 {
        M8([if b { !0 } else { 0 }; 8])
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> bool) -> M8 {
        M8(std::array::from_fn(|i| if f(i) { !0 } else { 0 }))
    }
    #[inline(always)]
    fn lane(self, i: usize) -> bool {
        self.0[i] != 0
    }
    #[inline(always)]
    fn any(self) -> bool {
        self.0.iter().fold(0, |a, &m| a | m) != 0
    }
    #[inline(always)]
    fn all(self) -> bool {
        self.0.iter().fold(!0, |a, &m| a & m) != 0
    }
}

impl Bits for U8 {
    type Mask = M8;
    const LANES: usize = 8;
    #[inline(always)]
    fn splat(x: u32) -> U8 {
        U8([x; 8])
    }
    #[inline(always)]
    fn from_fn(f: impl FnMut(usize) -> u32) -> U8 {
        U8(std::array::from_fn(f))
    }
    #[inline(always)]
    fn lane(self, i: usize) -> u32 {
        self.0[i]
    }
    #[inline(always)]
    fn wrapping_add(self, o: U8) -> U8 {
        U8(std::array::from_fn(|i| self.0[i].wrapping_add(o.0[i])))
    }
    #[inline(always)]
    fn wrapping_sub(self, o: U8) -> U8 {
        U8(std::array::from_fn(|i| self.0[i].wrapping_sub(o.0[i])))
    }
    #[inline(always)]
    fn wrapping_mul(self, o: U8) -> U8 {
        U8(std::array::from_fn(|i| self.0[i].wrapping_mul(o.0[i])))
    }
    #[inline(always)]
    fn shl(self, n: u32) -> U8 {
        U8(self.0.map(|x| x << n))
    }
    #[inline(always)]
    fn shr(self, n: u32) -> U8 {
        U8(self.0.map(|x| x >> n))
    }
    #[inline(always)]
    fn eq(self, o: U8) -> M8 {
        M8::from_fn(|i| self.0[i] == o.0[i])
    }
    #[inline(always)]
    fn lt(self, o: U8) -> M8 {
        M8::from_fn(|i| self.0[i] < o.0[i])
    }
    #[inline(always)]
    fn select(m: M8, a: U8, b: U8) -> U8 {
        U8(std::array::from_fn(|i| {
            (m.0[i] & a.0[i]) | (!m.0[i] & b.0[i])
        }))
    }
    #[inline(always)]
    fn reverse_bits(self) -> U8 {
        U8(self.0.map(u32::reverse_bits))
    }
    #[inline(always)]
    fn gather<const N: usize>(table: &[u32; N], index: U8) -> U8 {
        U8(index.0.map(|i| u32::gather(table, i)))
    }
    #[inline(always)]
    fn gather4<const N: usize>(table: &[[u32; 4]; N], index: U8) -> [U8; 4] {
        let rows = index.0.map(|i| u32::gather4(table, i));
        std::array::from_fn(|k| U8(std::array::from_fn(|i| rows[i][k])))
    }
    #[inline(always)]
    fn gather_slice(table: &[u32], index: U8) -> U8 {
        U8(index.0.map(|i| table[i as usize]))
    }
}

impl F8 {
    /// A lane-wise comparison as a mask.
    #[inline(always)]
    fn compare(self, o: F8, f: impl Fn(f32, f32) -> bool) -> M8 {
        M8::from_fn(|i| f(self.0[i], o.0[i]))
    }
}

impl Real for F8 {
    type Mask = M8;
    type Bits = U8;
    const LANES: usize = 8;
    const ZERO: F8 = F8([0.0; 8]);
    const ONE: F8 = F8([1.0; 8]);

    #[inline(always)]
    fn splat(x: f32) -> F8 {
        F8([x; 8])
    }
    #[inline(always)]
    fn from_fn(f: impl FnMut(usize) -> f32) -> F8 {
        F8(std::array::from_fn(f))
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self.0[i]
    }
    #[inline(always)]
    fn select(m: M8, a: F8, b: F8) -> F8 {
        // A blend of the bits, so that NaNs and signed zeros pass through unchanged.
        F8(std::array::from_fn(|i| {
            f32::from_bits((m.0[i] & a.0[i].to_bits()) | (!m.0[i] & b.0[i].to_bits()))
        }))
    }
    #[inline(always)]
    fn lt(self, o: F8) -> M8 {
        self.compare(o, |a, b| a < b)
    }
    #[inline(always)]
    fn le(self, o: F8) -> M8 {
        self.compare(o, |a, b| a <= b)
    }
    #[inline(always)]
    fn gt(self, o: F8) -> M8 {
        self.compare(o, |a, b| a > b)
    }
    #[inline(always)]
    fn ge(self, o: F8) -> M8 {
        self.compare(o, |a, b| a >= b)
    }
    #[inline(always)]
    fn eq(self, o: F8) -> M8 {
        self.compare(o, |a, b| a == b)
    }
    #[inline(always)]
    fn ne(self, o: F8) -> M8 {
        self.compare(o, |a, b| a != b)
    }
    #[inline(always)]
    fn sqrt(self) -> F8 {
        F8(self.0.map(f32::sqrt))
    }
    #[inline(always)]
    fn abs(self) -> F8 {
        F8(self.0.map(f32::abs))
    }
    #[inline(always)]
    fn floor(self) -> F8 {
        F8(self.0.map(f32::floor))
    }
    #[inline(always)]
    fn to_bits(self) -> U8 {
        U8(self.0.map(f32::to_bits))
    }
    #[inline(always)]
    fn from_bits(b: U8) -> F8 {
        F8(b.0.map(f32::from_bits))
    }
    #[inline(always)]
    fn trunc_i32(self) -> U8 {
        U8(self.0.map(|x| x as i32 as u32))
    }
    #[inline(always)]
    fn from_i32(b: U8) -> F8 {
        F8(b.0.map(|x| x as i32 as f32))
    }
    #[inline(always)]
    fn gather<const N: usize>(table: &[f32; N], index: U8) -> F8 {
        F8(index.0.map(|i| f32::gather(table, i)))
    }
    #[inline(always)]
    fn gather4(table: &[[f32; 4]], index: U8) -> [F8; 4] {
        let rows = index.0.map(|i| table[i as usize]);
        std::array::from_fn(|k| F8(std::array::from_fn(|i| rows[i][k])))
    }
    #[inline(always)]
    fn gather_slice(table: &[f32], index: U8) -> F8 {
        F8(index.0.map(|i| table[i as usize]))
    }
}

/// Work to run eight lanes wide: [`dispatch`] calls `run` with AVX2 and FMA enabled where
/// the processor has them. `run` and everything it calls on lanes must be
/// `#[inline(always)]`: what is not inlined into the AVX2 function is compiled once outside
/// it, as baseline code (correct, slower). A closure is not offered, because LLVM does not
/// inline a closure body of a shading kernel's size, which left it baseline.
pub trait Kernel {
    type Output;
    fn run(self) -> Self::Output;
}

/// Runs `kernel` with AVX2 and FMA enabled when the processor has them, chosen at run time
/// (`pulp`'s dispatch), and as baseline code otherwise: eight-lane code inlined into it
/// becomes 256-bit instructions. The result is the same bits either way.
#[inline(always)]
pub fn dispatch<K: Kernel>(kernel: K) -> K::Output {
    struct Adapter<K>(K);
    impl<K: Kernel> pulp::WithSimd for Adapter<K> {
        type Output = K::Output;
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, _simd: S) -> K::Output {
            self.0.run()
        }
    }
    pulp::Arch::new().dispatch(Adapter(kernel))
}

/// `$a` where mask `$m` is true and `$b` elsewhere, joined lane by lane by `$select(m, a, b)`;
/// each side is computed only when some lane takes it. At one lane this is an `if`, so a
/// one-lane caller pays only for the side it takes; at eight, a side no lane takes is
/// skipped. Either way a lane's result is the one its own side gives, so its bits do not
/// depend on the other lanes. A macro, not a function of two closures: LLVM leaves closures
/// of a lobe's size out of line, outside the AVX2 function ([`Kernel`]).
macro_rules! select_lazy {
    ($m:expr, $a:expr, $b:expr, $select:expr) => {{
        let m = $m;
        let a = match $crate::lanes::Mask::any(m) {
            true => Some($a),
            false => None,
        };
        let b = match $crate::lanes::Mask::all(m) {
            true => None,
            false => Some($b),
        };
        match (a, b) {
            (Some(a), Some(b)) => $select(m, a, b),
            (Some(a), None) => a,
            (None, Some(b)) => b,
            (None, None) => unreachable!("a mask is either all true or not"),
        }
    }};
}
pub(crate) use select_lazy;

/// A 2-vector of lanes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec2L<R> {
    pub x: R,
    pub y: R,
}

/// A 3-vector of lanes: eight directions as three [`F8`]s (structure of arrays), or one as
/// three `f32`s.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec3L<R> {
    pub x: R,
    pub y: R,
    pub z: R,
}

impl<R: Real> Vec2L<R> {
    #[inline(always)]
    pub fn new(x: R, y: R) -> Self {
        Vec2L { x, y }
    }
    /// Lane `i` of each component.
    #[inline(always)]
    pub fn lane(self, i: usize) -> glam::Vec2 {
        glam::Vec2::new(self.x.lane(i), self.y.lane(i))
    }
    /// Lane `i` from `f(i)`.
    #[inline(always)]
    pub fn from_fn(mut f: impl FnMut(usize) -> glam::Vec2) -> Self {
        let lanes: [glam::Vec2; 8] =
            std::array::from_fn(|i| if i < R::LANES { f(i) } else { glam::Vec2::ZERO });
        Vec2L::new(R::from_fn(|i| lanes[i].x), R::from_fn(|i| lanes[i].y))
    }
}

impl<R: Real> Vec3L<R> {
    #[inline(always)]
    pub fn new(x: R, y: R, z: R) -> Self {
        Vec3L { x, y, z }
    }
    #[inline(always)]
    pub fn splat(v: glam::Vec3) -> Self {
        Vec3L::new(R::splat(v.x), R::splat(v.y), R::splat(v.z))
    }
    /// Lane `i` of each component.
    #[inline(always)]
    pub fn lane(self, i: usize) -> glam::Vec3 {
        glam::Vec3::new(self.x.lane(i), self.y.lane(i), self.z.lane(i))
    }
    /// Lane `i` from `f(i)`.
    #[inline(always)]
    pub fn from_fn(mut f: impl FnMut(usize) -> glam::Vec3) -> Self {
        let lanes: [glam::Vec3; 8] =
            std::array::from_fn(|i| if i < R::LANES { f(i) } else { glam::Vec3::ZERO });
        Vec3L::new(
            R::from_fn(|i| lanes[i].x),
            R::from_fn(|i| lanes[i].y),
            R::from_fn(|i| lanes[i].z),
        )
    }
    /// `a` where `m` is true, `b` elsewhere.
    #[inline(always)]
    pub fn select(m: R::Mask, a: Self, b: Self) -> Self {
        Vec3L::new(
            R::select(m, a.x, b.x),
            R::select(m, a.y, b.y),
            R::select(m, a.z, b.z),
        )
    }
    #[inline(always)]
    pub fn dot(self, o: Self) -> R {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Vec3L::new(
            self.y * o.z - o.y * self.z,
            self.z * o.x - o.z * self.x,
            self.x * o.y - o.x * self.y,
        )
    }
    #[inline(always)]
    pub fn length_squared(self) -> R {
        self.dot(self)
    }
    #[inline(always)]
    pub fn length(self) -> R {
        self.length_squared().sqrt()
    }
    /// The unit vector along `self` (as glam's `normalize`: times the reciprocal length).
    #[inline(always)]
    pub fn normalize(self) -> Self {
        self * self.length().recip()
    }
    /// Every component `v`.
    #[inline(always)]
    pub fn all(v: R) -> Self {
        Vec3L::new(v, v, v)
    }
    /// `self·(1 − t) + o·t`, as glam's `lerp`.
    #[inline(always)]
    pub fn lerp(self, o: Self, t: R) -> Self {
        self * (R::ONE - t) + o * t
    }
    /// The largest component (as glam's `max_element` for components that are not NaN).
    #[inline(always)]
    pub fn max_element(self) -> R {
        self.x.max(self.y).max(self.z)
    }
    /// The component-wise maximum.
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        Vec3L::new(self.x.max(o.x), self.y.max(o.y), self.z.max(o.z))
    }
    /// The component-wise minimum.
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        Vec3L::new(self.x.min(o.x), self.y.min(o.y), self.z.min(o.z))
    }
}

impl<R: Real> Mul for Vec3L<R> {
    type Output = Self;
    /// The component-wise product (colours).
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Vec3L::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}

impl<R: Real> Div for Vec3L<R> {
    type Output = Self;
    /// The component-wise quotient (colours).
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        Vec3L::new(self.x / o.x, self.y / o.y, self.z / o.z)
    }
}

impl<R: Real> Add for Vec3L<R> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Vec3L::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl<R: Real> Sub for Vec3L<R> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Vec3L::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl<R: Real> Neg for Vec3L<R> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Vec3L::new(-self.x, -self.y, -self.z)
    }
}

impl<R: Real> Mul<R> for Vec3L<R> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: R) -> Self {
        Vec3L::new(self.x * s, self.y * s, self.z * s)
    }
}

impl From<glam::Vec3> for Vec3L<f32> {
    #[inline(always)]
    fn from(v: glam::Vec3) -> Self {
        Vec3L::new(v.x, v.y, v.z)
    }
}

impl From<Vec3L<f32>> for glam::Vec3 {
    #[inline(always)]
    fn from(v: Vec3L<f32>) -> Self {
        glam::Vec3::new(v.x, v.y, v.z)
    }
}

impl From<glam::Vec2> for Vec2L<f32> {
    #[inline(always)]
    fn from(v: glam::Vec2) -> Self {
        Vec2L::new(v.x, v.y)
    }
}

impl From<Vec2L<f32>> for glam::Vec2 {
    #[inline(always)]
    fn from(v: Vec2L<f32>) -> Self {
        glam::Vec2::new(v.x, v.y)
    }
}

/// Asserts that `$kernel::<R>([R; K]) -> [R; M]`, a function generic over [`Real`], gives at
/// eight lanes, inside and outside [`dispatch`], the bits it gives at one lane, for every
/// `[f32; K]` of `$inputs` (taken eight at a time; a last part-filled group repeats its last
/// input). The test of "one source, the same bits at every width" each generic routine has.
#[cfg(test)]
macro_rules! assert_same_bits_at_every_width {
    ($kernel:ident: [$k:literal] -> [$m:literal], $inputs:expr) => {
        $crate::lanes::assert_same_bits_at_every_width!(@run $kernel, $k, $m, $inputs, true)
    };
    // A whole lobe's kernel: eight lanes inside the dispatch only. Each instance of a lobe
    // takes minutes to compile, and what the baseline instance would add is tested where
    // it arises, op by op (the lanes' and the math's own width tests): the lobe's test is
    // there to catch a lane whose result depends on the others, which any eight-lane build
    // shows.
    ($kernel:ident: [$k:literal] -> [$m:literal], $inputs:expr, dispatched only) => {
        $crate::lanes::assert_same_bits_at_every_width!(@run $kernel, $k, $m, $inputs, false)
    };
    (@run $kernel:ident, $k:literal, $m:literal, $inputs:expr, $baseline:literal) => {{
        use $crate::lanes::{Real as _, F8};
        struct Wide([F8; $k]);
        impl $crate::lanes::Kernel for Wide {
            type Output = [F8; $m];
            #[inline(always)]
            fn run(self) -> [F8; $m] {
                $kernel::<F8>(self.0)
            }
        }
        let inputs: Vec<[f32; $k]> = $inputs.into_iter().collect();
        assert!(!inputs.is_empty());
        for chunk in inputs.chunks(8) {
            let lane = |i: usize| chunk[i.min(chunk.len() - 1)];
            let wide: [F8; $k] = std::array::from_fn(|j| F8::from_fn(|i| lane(i)[j]));
            let inside = $crate::lanes::dispatch(Wide(wide));
            let outside = match $baseline {
                true => $kernel::<F8>(wide),
                false => inside,
            };
            for i in 0..chunk.len() {
                let one: [f32; $m] = $kernel::<f32>(lane(i));
                for (m, v) in one.iter().enumerate() {
                    let (o, n) = (outside[m].lane(i), inside[m].lane(i));
                    assert_eq!(
                        o.to_bits(),
                        v.to_bits(),
                        "output {m}: {o} against {v} at {:?}",
                        lane(i)
                    );
                    assert_eq!(
                        n.to_bits(),
                        v.to_bits(),
                        "output {m} in dispatch at {:?}",
                        lane(i)
                    );
                }
            }
        }
    }};
}
#[cfg(test)]
pub(crate) use assert_same_bits_at_every_width;

#[cfg(test)]
mod tests {
    use super::*;

    /// Floats that exercise every operation's corners: signed zeros, subnormals, the
    /// largest and smallest normals, infinities, NaN, and ordinary values of both signs.
    fn awkward() -> Vec<f32> {
        let mut v = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-40,
            -1e-40,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            3.0e9,
            -3.0e9,
            2.5,
            -2.5,
            0.1,
            7.0,
        ];
        let mut state = 0x9e37_79b9u32;
        for _ in 0..300 {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            v.push(f32::from_bits(state));
            v.push((state >> 8) as f32 / (1 << 24) as f32 * 8.0 - 4.0);
        }
        v
    }

    /// Every pair of awkward floats, eight at a time: lane `i` of each [`F8`] operation, in
    /// and out of [`dispatch`], has the bits of the `f32` operation on lane `i`.
    #[test]
    fn eight_lanes_are_eight_single_lanes_bit_for_bit() {
        let values = awkward();
        let pairs: Vec<(f32, f32)> = values
            .iter()
            .flat_map(|&a| values.iter().map(move |&b| (a, b)))
            .collect();
        type Ops<R> = [fn(R, R) -> R; 14];
        fn ops<R: Real>() -> Ops<R> {
            [
                |a, b| a + b,
                |a, b| a - b,
                |a, b| a * b,
                |a, b| a / b,
                |a, _| -a,
                |a, _| a.sqrt(),
                |a, _| a.abs(),
                |a, _| a.floor(),
                |a, b| a.min(b),
                |a, b| a.max(b),
                |a, b| a.copysign(b),
                |a, b| R::select(a.lt(b), a, b * 2.0),
                |a, b| R::from_i32(a.trunc_i32()) + R::from_bits(b.to_bits().shr(1)),
                |a, b| R::select(a.eq(b) | a.ge(b), R::ONE, R::ZERO),
            ]
        }
        let (one, eight) = (ops::<f32>(), ops::<F8>());
        for chunk in pairs.chunks(8) {
            let lane = |i: usize| chunk.get(i).copied().unwrap_or((0.0, 0.0));
            let a = F8::from_fn(|i| lane(i).0);
            let b = F8::from_fn(|i| lane(i).1);
            for (k, (f1, f8)) in one.iter().zip(&eight).enumerate() {
                struct Op(fn(F8, F8) -> F8, F8, F8);
                // (Called through a pointer, the operation stays outside the AVX2 function;
                // the routines' own tests inline theirs.)
                impl Kernel for Op {
                    type Output = F8;
                    #[inline(always)]
                    fn run(self) -> F8 {
                        (self.0)(self.1, self.2)
                    }
                }
                let outside = f8(a, b);
                let inside = dispatch(Op(*f8, a, b));
                for i in 0..8 {
                    let want = f1(lane(i).0, lane(i).1).to_bits();
                    assert_eq!(outside.0[i].to_bits(), want, "op {k} on {:?}", lane(i));
                    assert_eq!(
                        inside.0[i].to_bits(),
                        want,
                        "op {k} in dispatch, {:?}",
                        lane(i)
                    );
                }
            }
        }
    }

    /// The test above would see a width that rounds differently: a fused multiply-add
    /// differs from the twice-rounded product and sum on some of the same inputs.
    #[test]
    fn a_fused_multiply_add_would_be_caught() {
        let values = awkward();
        let differs = values
            .iter()
            .flat_map(|&a| values.iter().map(move |&b| (a, b)))
            .filter(|&(a, b)| a.is_finite() && b.is_finite())
            .any(|(a, b)| a.mul_add(b, 0.1).to_bits() != (a * b + 0.1).to_bits());
        assert!(differs);
    }

    /// The check every generic routine's test uses catches a kernel whose eight-lane form
    /// rounds differently from its one-lane form.
    #[test]
    #[should_panic(expected = "output 0")]
    fn the_width_check_catches_a_kernel_that_depends_on_its_width() {
        #[inline(always)]
        fn kernel<R: Real>([a, b]: [R; 2]) -> [R; 1] {
            // A reciprocal then a product at eight lanes, a quotient at one.
            if R::LANES == 8 {
                [a * b.recip()]
            } else {
                [a / b]
            }
        }
        let mut next = crate::sampling::hash::uniform_sequence(1);
        assert_same_bits_at_every_width!(kernel: [2] -> [1], (0..64).map(|_| [next(), next() + 0.1]));
    }

    #[test]
    fn masks_and_words_reduce_and_wrap() {
        let m = M8::from_fn(|i| i == 3);
        assert!(m.any() && !m.all() && !m.none() && m.lane(3) && !m.lane(2));
        assert!(M8::splat(true).all() && M8::splat(false).none());
        let u = U8::from_fn(|i| u32::MAX - i as u32);
        assert_eq!(u.wrapping_add(U8::splat(2)).lane(0), 1);
        assert_eq!(U8::splat(0x8000_0001).wrapping_mul(U8::splat(2)).lane(5), 2);
        assert_eq!(U8::splat(1).shl(31).shr(30).lane(7), 2);
        assert_eq!(
            U8::select(m, U8::splat(7), U8::splat(9)).0,
            [9, 9, 9, 7, 9, 9, 9, 9]
        );
        let table = [10.0, 20.0, 30.0];
        assert_eq!(
            F8::gather(&table, U8::from_fn(|i| (i % 3) as u32)).lane(4),
            20.0
        );
        assert!(<bool as Mask>::splat(true).all() && Bits::lt(1u32, 2));
    }

    #[test]
    fn vectors_agree_with_glam() {
        let (a, b) = (
            glam::Vec3::new(0.3, -1.2, 2.0),
            glam::Vec3::new(-0.7, 0.4, 0.9),
        );
        let (la, lb) = (Vec3L::<F8>::splat(a), Vec3L::<F8>::splat(b));
        for i in 0..8 {
            assert_eq!(la.cross(lb).lane(i), a.cross(b));
            assert_eq!(la.dot(lb).lane(i), a.dot(b));
            assert_eq!(la.normalize().lane(i), a.normalize());
            assert_eq!((la - lb * F8::splat(2.0)).lane(i), a - b * 2.0);
        }
        let v: glam::Vec3 = Vec3L::from(a).normalize().into();
        assert_eq!(v, a.normalize());
        let (la, lb) = (Vec3L::from(a), Vec3L::from(b));
        assert_eq!(glam::Vec3::from(la.lerp(lb, 0.3)), a.lerp(b, 0.3));
        assert_eq!(la.max_element(), a.max_element());
        assert_eq!(glam::Vec3::from(la * lb), a * b);
        assert_eq!(glam::Vec3::from(la.max(lb)), a.max(b));
        assert_eq!(glam::Vec3::from(la.min(lb)), a.min(b));
        assert_eq!(glam::Vec3::from(Vec3L::all(0.25)), glam::Vec3::splat(0.25));
    }
}
