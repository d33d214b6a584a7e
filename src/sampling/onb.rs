//! An orthonormal basis around a unit vector, after Duff, Burgess, Christensen, Hery, Kensler,
//! Liani & Villemin, "Building an Orthonormal Basis, Revisited" (JCGT 2017): branchless and
//! stable as n.z → −1, unlike Frisvad's original construction. Written once over [`Real`]
//! ([`Frame`]); [`Onb`] is its one-lane, glam-typed face.

use crate::lanes::{Real, Vec3L};
use glam::Vec3;

/// A right-handed frame (t, b, n) of one lane or several: t × b = n.
#[derive(Clone, Copy, Debug)]
pub struct Frame<R> {
    pub t: Vec3L<R>,
    pub b: Vec3L<R>,
    pub n: Vec3L<R>,
}

impl<R: Real> Frame<R> {
    /// The frame around unit vector `n` (Duff et al. 2017, listing 3).
    #[inline(always)]
    pub fn from_normal(n: Vec3L<R>) -> Frame<R> {
        let sign = R::ONE.copysign(n.z);
        let a = -(sign + n.z).recip();
        let b = n.x * n.y * a;
        Frame {
            t: Vec3L::new(sign * n.x * n.x * a + 1.0, sign * b, -sign * n.x),
            b: Vec3L::new(b, n.y * n.y * a + sign, -n.y),
            n,
        }
    }

    /// Local (x, y, z) → world, z along n.
    #[inline(always)]
    pub fn to_world(&self, v: Vec3L<R>) -> Vec3L<R> {
        self.t * v.x + self.b * v.y + self.n * v.z
    }

    /// World → local coordinates of this frame.
    #[inline(always)]
    pub fn to_local(&self, v: Vec3L<R>) -> Vec3L<R> {
        Vec3L::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }
}

/// A right-handed frame (t, b, n): t × b = n.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Onb {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Onb {
    /// The frame around unit vector `n` (Duff et al. 2017, listing 3).
    #[inline]
    pub fn from_normal(n: Vec3) -> Onb {
        let f = Frame::from_normal(n.into());
        Onb {
            t: f.t.into(),
            b: f.b.into(),
            n,
        }
    }

    #[inline(always)]
    fn frame(&self) -> Frame<f32> {
        Frame {
            t: self.t.into(),
            b: self.b.into(),
            n: self.n.into(),
        }
    }

    /// Local (x, y, z) → world, z along n.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.frame().to_world(v.into()).into()
    }

    /// World → local coordinates of this frame.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        self.frame().to_local(v.into()).into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frames around random normals (the south pole's neighbourhood among them), and
    /// vectors taken to world and back: eight lanes give the bits of one.
    #[test]
    fn frames_have_the_same_bits_at_every_width() {
        #[inline(always)]
        fn kernel<R: Real>([x, y, z, a, b, c]: [R; 6]) -> [R; 9] {
            let f = Frame::from_normal(Vec3L::new(x, y, z).normalize());
            let w = f.to_world(Vec3L::new(a, b, c));
            let l = f.to_local(w);
            [f.t.x, f.t.y, f.t.z, f.b.x, f.b.y, w.x, w.y, w.z, l.x]
        }
        let mut next = crate::sampling::hash::uniform_sequence(49);
        let mut inputs: Vec<[f32; 6]> = (0..20_000)
            .map(|_| std::array::from_fn(|_| next() * 2.0 - 1.0))
            .collect();
        inputs.push([0.0, 0.0, -1.0, 0.3, 0.2, 0.1]);
        inputs.push([1e-4, -1e-4, -1.0, 0.3, 0.2, 0.1]);
        inputs.push([0.0, 0.0, 1.0, 1.0, 0.0, 0.0]);
        crate::lanes::assert_same_bits_at_every_width!(kernel: [6] -> [9], inputs);
    }

    /// The frame is orthonormal and right-handed, down to the south pole.
    #[test]
    fn frames_are_orthonormal() {
        let mut next = crate::sampling::hash::uniform_sequence(50);
        let normals = (0..10_000)
            .map(|_| Vec3::new(next() * 2.0 - 1.0, next() * 2.0 - 1.0, next() * 2.0 - 1.0))
            .filter(|v| v.length() > 1e-3)
            .map(Vec3::normalize)
            .chain([Vec3::Z, -Vec3::Z, Vec3::new(1e-5, 0.0, -1.0).normalize()]);
        for n in normals {
            let f = Onb::from_normal(n);
            for (u, v) in [(f.t, f.b), (f.b, f.n), (f.n, f.t)] {
                assert!(u.dot(v).abs() < 1e-5, "{n}: {u} · {v}");
            }
            assert!((f.t.length() - 1.0).abs() < 1e-5 && (f.b.length() - 1.0).abs() < 1e-5);
            assert!(
                (f.t.cross(f.b) - n).length() < 1e-5,
                "{n}: not right-handed"
            );
            let v = Vec3::new(0.3, -0.5, 0.8);
            assert!((f.to_local(f.to_world(v)) - v).length() < 1e-5);
        }
    }
}
