//! An orthonormal basis around a unit vector, after Duff, Burgess, Christensen, Hery, Kensler,
//! Liani & Villemin, "Building an Orthonormal Basis, Revisited" (JCGT 2017): branchless and
//! stable as n.z → −1, unlike Frisvad's original construction.

use glam::Vec3;

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
        let sign = 1f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Onb {
            t: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            b: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    /// Local (x, y, z) → world, z along n.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        v.x * self.t + v.y * self.b + v.z * self.n
    }

    /// World → local coordinates of this frame.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }
}
