//! Cameras: glTF perspective and orthographic projections, and the framing camera used when a
//! file has none.

use glam::{DMat4, Mat4, Vec3};

use crate::ray::Ray;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Vertical field of view in radians.
    Perspective { yfov: f32 },
    /// Half-height of the view volume in scene units (glTF `ymag`).
    Orthographic { ymag: f32 },
}

/// A camera in world space. It looks down its local −Z with +Y up (glTF convention); the
/// image's aspect ratio comes from the output resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub name: Option<String>,
    pub projection: Projection,
    /// Camera-to-world transform (rotation and translation; any scale is divided out of
    /// ray directions by normalisation).
    pub to_world: Mat4,
    /// glTF `aspectRatio`, if the file gives one (used for the default resolution).
    pub aspect_ratio: Option<f32>,
    /// A thin lens (depth of field); None: a pinhole, everything in focus.
    pub lens: Option<Lens>,
}

/// A thin lens: rays leave a disk of radius `radius` about the camera's position, square to
/// its view, and meet where the pinhole's ray through the same film position meets the plane
/// of focus, `focus_distance` ahead along the view (pbrt-v4 §5.2.3). Scene units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    pub radius: f32,
    pub focus_distance: f32,
}

impl Lens {
    /// The sensor's width across the image's larger side for `--f-stop`: 36 mm, a full-frame
    /// 35 mm camera's, as Blender's default sensor (fit "auto").
    pub const SENSOR_MM: f32 = 36.0;

    /// The lens whose aperture is f-number `f_stop` for a perspective camera of vertical field
    /// of view `yfov` on an image of aspect ratio `aspect`, in a scene of metres (glTF's
    /// unit): focal length f = (36 mm / 2) / tan(half the larger side's field of view), and
    /// the aperture's diameter f / N.
    pub fn from_f_stop(f_stop: f32, yfov: f32, aspect: f32, focus_distance: f32) -> Lens {
        let tan_larger = (0.5 * yfov).tan() * aspect.max(1.0);
        let focal_mm = 0.5 * Lens::SENSOR_MM / tan_larger;
        Lens {
            radius: 0.5 * focal_mm / f_stop / 1000.0,
            focus_distance,
        }
    }
}

impl Camera {
    /// The vertical field of view of a file without a camera (the framing camera's).
    pub const FRAMING_YFOV_DEGREES: f32 = 45.0;

    /// The camera that frames bounds `(lo, hi)` from +Z with a 45° vertical field of view,
    /// for files without a camera ([`Camera::framing_with`]).
    pub fn framing(lo: Vec3, hi: Vec3, aspect: f32) -> Camera {
        Camera::framing_with(lo, hi, aspect, Camera::FRAMING_YFOV_DEGREES.to_radians())
    }

    /// The camera that looks at bounds `(lo, hi)` from +Z (down −Z, +Y up) with vertical field
    /// of view `yfov`, as close as it can be with all eight corners of the box inside the
    /// image of aspect ratio `aspect`, a margin of 5% of the half-width and half-height
    /// around them. For a corner at (x, y, z) from the box's centre, a camera at distance d
    /// sees it at depth d − z, inside the image when |x| ≤ tan(h)·(d − z) for the half field
    /// of view h along x (and likewise y), so d is the largest z + |x|/tan(h) over the corners.
    pub fn framing_with(lo: Vec3, hi: Vec3, aspect: f32, yfov: f32) -> Camera {
        let center = 0.5 * (lo + hi);
        let half = 0.5 * (hi - lo);
        let fill = 0.95;
        let tan_y = (0.5 * yfov).tan() * fill;
        let tan_x = (0.5 * yfov).tan() * aspect * fill;
        let mut distance = 0f32;
        for corner in 0..8 {
            let signs = Vec3::new(
                if corner & 1 == 0 { -1.0 } else { 1.0 },
                if corner & 2 == 0 { -1.0 } else { 1.0 },
                if corner & 4 == 0 { -1.0 } else { 1.0 },
            );
            let c = half * signs;
            distance = distance
                .max(c.z + c.x.abs() / tan_x)
                .max(c.z + c.y.abs() / tan_y);
        }
        // A flat or empty box still needs room in front of it.
        let distance = distance.max(half.z + 1e-3 * half.length().max(1e-3));
        Camera {
            name: Some("framing camera".into()),
            projection: Projection::Perspective { yfov },
            to_world: Mat4::from_translation(center + Vec3::new(0.0, 0.0, distance)),
            aspect_ratio: None,
            lens: None,
        }
    }

    /// The camera's position in world space.
    pub fn position(&self) -> Vec3 {
        self.to_world.w_axis.truncate()
    }

    /// This camera moved to `from` and turned to look at `at` with `up` as the image's up
    /// (its projection kept); None when `from` is `at` or `up` is along the view direction.
    pub fn looking(&self, from: Vec3, at: Vec3, up: Vec3) -> Option<Camera> {
        let forward = (at - from).normalize_or_zero();
        let side = forward.cross(up).normalize_or_zero();
        if forward == Vec3::ZERO || side == Vec3::ZERO {
            return None;
        }
        let true_up = side.cross(forward);
        // Local −Z is the view direction, +Y up, +X to the right.
        let to_world = Mat4::from_cols(
            side.extend(0.0),
            true_up.extend(0.0),
            (-forward).extend(0.0),
            from.extend(1.0),
        );
        Some(Camera {
            to_world,
            ..self.clone()
        })
    }

    /// This camera turned by `angle` radians about the vertical (+Y) axis through `pivot`,
    /// counter-clockwise seen from above.
    pub fn orbited(&self, pivot: Vec3, angle: f32) -> Camera {
        let turn = Mat4::from_translation(pivot)
            * Mat4::from_rotation_y(angle)
            * Mat4::from_translation(-pivot);
        Camera {
            to_world: turn * self.to_world,
            ..self.clone()
        }
    }

    /// The primary ray through film position (fx, fy), in pixels from the top-left corner of
    /// a `width × height` image. For many rays, make a [`RayGenerator`] once.
    #[inline]
    pub fn generate_ray(&self, fx: f32, fy: f32, width: u32, height: u32) -> Ray {
        self.ray_generator(width, height).ray(fx, fy)
    }

    /// The camera's primary rays for a `width × height` image, with everything that does not
    /// depend on the film position computed once.
    pub fn ray_generator(&self, width: u32, height: u32) -> RayGenerator {
        let (w, h) = (width as f32, height as f32);
        let aspect = w / h;
        // Film position (fx, fy) → normalised device coordinates x = 2·fx/w − 1,
        // y = 1 − 2·fy/h (+y up); the camera-space point is (x·sx, y·sy, z) and a step of one
        // pixel moves it by (2·sx/w, −2·sy/h).
        let (sx, sy, z) = match self.projection {
            Projection::Perspective { yfov } => {
                let tan_half = (0.5 * yfov).tan();
                (tan_half * aspect, tan_half, -1.0)
            }
            Projection::Orthographic { ymag } => (ymag * aspect, ymag, 0.0),
        };
        let m = &self.to_world;
        let corner = Vec3::new(-sx, sy, z);
        let du = m.transform_vector3(Vec3::new(2.0 * sx / w, 0.0, 0.0));
        let dv = m.transform_vector3(Vec3::new(0.0, -2.0 * sy / h, 0.0));
        match (self.projection, self.lens) {
            (Projection::Perspective { .. }, Some(lens)) if lens.radius > 0.0 => {
                // The film's directions have unit depth (z = −1 in camera space), so the
                // pinhole ray through a film position meets the plane of focus at
                // org + focus_distance · d.
                // A scaled camera's film directions have depth s (the scale), not 1.
                let depth = m.transform_vector3(Vec3::NEG_Z).length();
                RayGenerator::ThinLens {
                    org: m.transform_point3(Vec3::ZERO),
                    corner: m.transform_vector3(corner),
                    du,
                    dv,
                    right: m.transform_vector3(Vec3::X).normalize() * lens.radius,
                    up: m.transform_vector3(Vec3::Y).normalize() * lens.radius,
                    focus: lens.focus_distance / depth,
                }
            }
            (Projection::Perspective { .. }, _) => RayGenerator::Perspective {
                org: m.transform_point3(Vec3::ZERO),
                corner: m.transform_vector3(corner),
                du,
                dv,
            },
            (Projection::Orthographic { .. }, _) => RayGenerator::Orthographic {
                corner: m.transform_point3(corner),
                du,
                dv,
                dir: m.transform_vector3(Vec3::NEG_Z).normalize(),
            },
        }
    }
}

/// A camera's primary rays for one image size (see [`Camera::ray_generator`]): world-space
/// film corner and per-pixel steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RayGenerator {
    /// Rays from `org` through `corner + fx·du + fy·dv`, normalised.
    Perspective {
        org: Vec3,
        corner: Vec3,
        du: Vec3,
        dv: Vec3,
    },
    /// Parallel rays along `dir` from `corner + fx·du + fy·dv`.
    Orthographic {
        corner: Vec3,
        du: Vec3,
        dv: Vec3,
        dir: Vec3,
    },
    /// A thin lens ([`Lens`]): rays from `org + lx·right + ly·up` for a point (lx, ly) of the
    /// unit disk, toward `org + focus · (corner + fx·du + fy·dv)`, the pinhole ray's point on
    /// the plane of focus.
    ThinLens {
        org: Vec3,
        corner: Vec3,
        du: Vec3,
        dv: Vec3,
        right: Vec3,
        up: Vec3,
        focus: f32,
    },
}

impl RayGenerator {
    /// The ray through film position (fx, fy), in pixels from the top-left corner.
    #[inline]
    pub fn ray(&self, fx: f32, fy: f32) -> Ray {
        match *self {
            RayGenerator::Perspective {
                org,
                corner,
                du,
                dv,
            } => Ray::new(org, (corner + fx * du + fy * dv).normalize()),
            RayGenerator::Orthographic {
                corner,
                du,
                dv,
                dir,
            } => Ray::new(corner + fx * du + fy * dv, dir),
            // The ray through the lens's centre: the pinhole's.
            RayGenerator::ThinLens {
                org,
                corner,
                du,
                dv,
                ..
            } => Ray::new(org, (corner + fx * du + fy * dv).normalize()),
        }
    }

    /// Whether rays depend on a point of the lens ([`RayGenerator::rays_through_lens`]).
    pub fn has_lens(&self) -> bool {
        matches!(self, RayGenerator::ThinLens { .. })
    }

    /// The rays through film positions `(fx[i], fy[i])` and points `lens[i]` of the unit disk
    /// (the lens, scaled to its radius here); without a lens, [`RayGenerator::rays`].
    #[inline]
    pub fn rays_through_lens<const N: usize>(
        &self,
        fx: &[f32; N],
        fy: &[f32; N],
        lens: &[glam::Vec2; N],
    ) -> [Ray; N] {
        let RayGenerator::ThinLens {
            org,
            corner,
            du,
            dv,
            right,
            up,
            focus,
        } = *self
        else {
            return self.rays(fx, fy);
        };
        std::array::from_fn(|i| {
            let on_focus = org + focus * (corner + fx[i] * du + fy[i] * dv);
            let from = org + lens[i].x * right + lens[i].y * up;
            Ray::new(from, (on_focus - from).normalize())
        })
    }

    /// The rays through film positions `(fx[i], fy[i])`, each bit-identical to
    /// [`RayGenerator::ray`]'s, computed lane by lane over arrays: the square roots and
    /// divisions of the normalisations then run side by side (packed, where the compiler
    /// vectorises the loops) instead of each waiting on its predecessor.
    #[inline]
    pub fn rays<const N: usize>(&self, fx: &[f32; N], fy: &[f32; N]) -> [Ray; N] {
        let RayGenerator::Perspective {
            org,
            corner,
            du,
            dv,
        } = *self
        else {
            // Orthographic rays need no normalisation: nothing to overlap.
            return std::array::from_fn(|i| self.ray(fx[i], fy[i]));
        };
        // The operations of `ray`, in its order: (corner + fx·du) + fy·dv, then
        // d · (1 / √(d·d)) as glam's `normalize`.
        let axis = |c: usize| -> [f32; N] {
            std::array::from_fn(|i| corner[c] + fx[i] * du[c] + fy[i] * dv[c])
        };
        let (x, y, z) = (axis(0), axis(1), axis(2));
        let inv: [f32; N] =
            std::array::from_fn(|i| 1.0 / ((x[i] * x[i]) + (y[i] * y[i]) + (z[i] * z[i])).sqrt());
        std::array::from_fn(|i| {
            Ray::new(org, Vec3::new(x[i] * inv[i], y[i] * inv[i], z[i] * inv[i]))
        })
    }

    /// A rectangle of film positions `[x0, x1] × [y0, y1]`, in pixels, such that no ray of
    /// [`RayGenerator::ray`] from a film position of the `width × height` image outside it
    /// can meet the box `lo`..`hi` (empty, x0 > x1, when none in the image can); or None
    /// where no such rectangle is found (a perspective camera inside the box, a degenerate
    /// camera, non-finite input). The renderer leaves pixel blocks outside the rectangles of
    /// all the scene's cluster boxes untraced ([`crate::accel::culling`]).
    ///
    /// A film position f sees a point q when q lies on f's ray, so f is q's image under the
    /// camera's projection. For an orthographic camera the projection is affine, and every
    /// point of the box has its image in the bounding rectangle of its eight corners'. For a
    /// perspective one, write q = org + a·corner + b·du + c·dv: the ray through f reaches q
    /// at a = t (along the unnormalised direction d(f)), with f = (b/a, c/a). A box point at
    /// distance r or more from the centre is reached at t ≥ r/|d(f)| ≥ r/K, K bounding |d|
    /// over the image; so with ε = r/(2K), r the box's distance from the centre, only the
    /// part of the box with a ≥ ε can be seen from the image, and the projection maps that
    /// convex part onto the hull of its vertices' images: the corners with a ≥ ε and the
    /// points where the box's edges cross a = ε (none: the box is behind the camera).
    /// Everything is solved in f64, on a box widened by 64 ulps of the largest coordinate in
    /// play, and the rectangle is grown by one pixel plus the film distance that the f32
    /// rounding of a ray's origin and direction can move it (16 ulps of their largest term,
    /// over a pixel's step), so that the rays the renderer makes from f32 film positions stay
    /// inside it too (tests/scene_box.rs aims such rays at boxes' corners, edges and faces).
    pub fn film_bounds(&self, lo: Vec3, hi: Vec3, width: u32, height: u32) -> Option<[f32; 4]> {
        use glam::{DMat3, DVec3};
        let (w, h) = (width as f64, height as f64);
        // Solve q − base = m · (a, b, c) for each corner q; the film position is (b/a, c/a)
        // (perspective) or (a, b) (orthographic, c the distance along the ray).
        let (base, m, perspective, largest, reach) = match *self {
            // Rays from all over the lens: no film rectangle bounds them simply.
            RayGenerator::ThinLens { .. } => return None,
            RayGenerator::Perspective {
                org,
                corner,
                du,
                dv,
            } => {
                let (corner, du, dv) = (corner.as_dvec3(), du.as_dvec3(), dv.as_dvec3());
                let largest = corner.abs().max_element()
                    + w * du.abs().max_element()
                    + h * dv.abs().max_element();
                // K: |d(f)| ≤ |corner| + fx·|du| + fy·|dv| over the image.
                let reach = corner.length() + w * du.length() + h * dv.length();
                (org, DMat3::from_cols(corner, du, dv), true, largest, reach)
            }
            RayGenerator::Orthographic {
                corner,
                du,
                dv,
                dir,
            } => {
                let (c, du, dv) = (corner.as_dvec3(), du.as_dvec3(), dv.as_dvec3());
                let largest =
                    c.abs().max_element() + w * du.abs().max_element() + h * dv.abs().max_element();
                let m = DMat3::from_cols(du, dv, dir.as_dvec3());
                (corner, m, false, largest, 0.0)
            }
        };
        let step = match *self {
            RayGenerator::Perspective { du, dv, .. }
            | RayGenerator::Orthographic { du, dv, .. }
            | RayGenerator::ThinLens { du, dv, .. } => du.length().min(dv.length()) as f64,
        };
        let inv = m.inverse();
        if !(inv.is_finite() && step > 0.0 && lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let eps = f32::EPSILON as f64;
        let scale = lo.abs().max(hi.abs()).max(base.abs()).max_element() as f64;
        let widen = DVec3::splat(64.0 * eps * scale);
        let (lo, hi) = (lo.as_dvec3() - widen, hi.as_dvec3() + widen);
        let base = base.as_dvec3();
        let solved: [DVec3; 8] = std::array::from_fn(|i| {
            let q = DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            inv * (q - base)
        });
        let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        let mut add = |fx: f64, fy: f64| {
            (x0, y0, x1, y1) = (x0.min(fx), y0.min(fy), x1.max(fx), y1.max(fy));
        };
        if perspective {
            let distance = (base.clamp(lo, hi) - base).length();
            let near = 0.5 * distance / reach;
            if !(near > 0.0 && near.is_finite()) {
                return None;
            }
            for (i, s) in solved.iter().enumerate() {
                if s.x >= near {
                    add(s.y / s.x, s.z / s.x);
                }
                // The box's edges from this corner (to the corner one bit higher) that cross
                // a = ε, at their crossing.
                for bit in [1, 2, 4] {
                    let t = solved[i | bit];
                    if i & bit == 0 && (s.x < near) != (t.x < near) {
                        let p = *s + (t - *s) * ((near - s.x) / (t.x - s.x));
                        add(p.y / near, p.z / near);
                    }
                }
            }
            if x0 > x1 {
                // Nothing of the box lies at a ≥ ε: behind the camera, unseen.
                return Some([f32::MAX, f32::MAX, f32::MIN, f32::MIN]);
            }
        } else {
            for s in &solved {
                add(s.x, s.y);
            }
        }
        // One pixel, the rounding of the rays (see above), and that of the rectangle's own
        // conversion to f32.
        let extent = [x0, y0, x1, y1]
            .map(f64::abs)
            .into_iter()
            .fold(0.0, f64::max);
        let margin = 1.0 + 16.0 * eps * largest / step + 4.0 * eps * extent;
        let rect = [x0 - margin, y0 - margin, x1 + margin, y1 + margin];
        // Beyond f32's range the rectangle says nothing useful.
        rect.iter()
            .all(|v| v.abs() < 1e30)
            .then(|| rect.map(|v| v as f32))
    }
}

/// The camera a glTF node places with its world transform `world`; an error for a
/// projection glTF does not allow.
pub(super) fn from_gltf(camera: &gltf::Camera, world: &DMat4) -> Result<Camera, String> {
    let label = format!("camera {}", camera.index());
    let (projection, aspect_ratio) = match camera.projection() {
        gltf::camera::Projection::Perspective(p) => {
            let yfov = p.yfov();
            if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
                return Err(format!("{label}: yfov {yfov} is not in (0, π)"));
            }
            let aspect = p.aspect_ratio();
            if let Some(a) = aspect {
                if !(a > 0.0 && a.is_finite()) {
                    return Err(format!("{label}: aspectRatio {a} is not positive"));
                }
            }
            (Projection::Perspective { yfov }, aspect)
        }
        gltf::camera::Projection::Orthographic(o) => {
            let (xmag, ymag) = (o.xmag(), o.ymag());
            if !(ymag > 0.0 && ymag.is_finite() && xmag > 0.0 && xmag.is_finite()) {
                return Err(format!(
                    "{label}: xmag {xmag} and ymag {ymag} must be positive"
                ));
            }
            (Projection::Orthographic { ymag }, Some(xmag / ymag))
        }
    };
    let to_world = world.as_mat4();
    if !to_world.is_finite() {
        return Err(format!(
            "{label}: its world transform overflows single precision"
        ));
    }
    Ok(Camera {
        name: camera.name().map(str::to_string),
        projection,
        to_world,
        aspect_ratio,
        lens: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lens_rays_leave_the_lens_and_meet_the_pinhole_ray_on_the_plane_of_focus() {
        // A camera at (1, 2, 3) turned to look along −X, a lens 0.4 across focused at 5.
        let pinhole = Camera::framing(Vec3::splat(-1.0), Vec3::splat(1.0), 1.5)
            .looking(Vec3::new(1.0, 2.0, 3.0), Vec3::new(-4.0, 2.0, 3.0), Vec3::Y)
            .unwrap();
        let lensed = Camera {
            lens: Some(Lens {
                radius: 0.2,
                focus_distance: 5.0,
            }),
            ..pinhole.clone()
        };
        let (g, p) = (lensed.ray_generator(60, 40), pinhole.ray_generator(60, 40));
        assert!(g.has_lens() && !p.has_lens());
        let disk = [
            glam::Vec2::new(1.0, 0.0),
            glam::Vec2::new(-0.6, 0.8),
            glam::Vec2::new(0.1, -0.3),
            glam::Vec2::ZERO,
        ];
        let (fx, fy) = ([0.5, 30.0, 59.5, 12.25], [0.5, 20.0, 39.5, 33.0]);
        let rays = g.rays_through_lens(&fx, &fy, &disk);
        let through = p.rays(&fx, &fy);
        let org = Vec3::new(1.0, 2.0, 3.0);
        for i in 0..4 {
            let (r, q) = (rays[i], through[i]);
            // From the lens: in the plane x = 1 (square to the view), within its radius, at
            // the disk point's place (right is −Z looking along −X, up +Y).
            let off = r.org - org;
            assert!(off.x.abs() < 1e-6, "{off}");
            let want = 0.2 * Vec3::new(0.0, disk[i].y, -disk[i].x);
            assert!((off - want).length() < 1e-5, "{off} against {want}");
            // Both reach the plane of focus, x = 1 − 5, at one point.
            let at = |o: Vec3, d: Vec3| o + d * ((-4.0 - o.x) / d.x);
            let (a, b) = (at(r.org, r.dir), at(q.org, q.dir));
            assert!((a - b).length() < 1e-4, "ray {i}: {a} against {b}");
            assert!((r.dir.length() - 1.0).abs() < 1e-6);
        }
        // The lens's centre gives the pinhole's ray.
        assert!((rays[3].dir - through[3].dir).length() < 1e-6);
        assert!(g.film_bounds(Vec3::ZERO, Vec3::ONE, 60, 40).is_none());
    }

    #[test]
    fn an_f_number_is_the_focal_length_over_the_aperture() {
        // 50 mm on a 36 mm sensor across a 3:2 image's width: tan(h/2) = 18/50 along x, so
        // tan(v/2) = 0.24 along y; f/2 is 25 mm across, a radius of 0.0125 m.
        let yfov = 2.0 * 0.24f32.atan();
        let lens = Lens::from_f_stop(2.0, yfov, 1.5, 3.0);
        assert!((lens.radius - 0.0125).abs() < 1e-6, "{}", lens.radius);
        assert_eq!(lens.focus_distance, 3.0);
        // A portrait image's larger side is its height: tan(v/2) = 18/50 there.
        let portrait = Lens::from_f_stop(4.0, 2.0 * 0.36f32.atan(), 0.5, 1.0);
        assert!(
            (portrait.radius - 0.00625).abs() < 1e-6,
            "{}",
            portrait.radius
        );
    }

    #[test]
    fn generated_rays_follow_the_gltf_camera_convention() {
        // A camera at (1, 2, 3) looking down −Z, yfov 90°: the image's top-left corner ray
        // points to (−aspect, +1, −1), the centre ray straight down −Z.
        let cam = Camera {
            name: None,
            projection: Projection::Perspective {
                yfov: std::f32::consts::FRAC_PI_2,
            },
            to_world: Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)),
            aspect_ratio: None,
            lens: None,
        };
        let centre = cam.generate_ray(100.0, 50.0, 200, 100);
        assert_eq!(centre.org, Vec3::new(1.0, 2.0, 3.0));
        assert!((centre.dir - Vec3::NEG_Z).length() < 1e-6);
        let corner = cam.generate_ray(0.0, 0.0, 200, 100);
        assert!(
            (corner.dir - Vec3::new(-2.0, 1.0, -1.0).normalize()).length() < 1e-6,
            "{}",
            corner.dir
        );
        // Orthographic: parallel rays, origins spread over ±ymag·aspect × ±ymag.
        let ortho = Camera {
            projection: Projection::Orthographic { ymag: 2.0 },
            ..cam
        };
        let r = ortho.generate_ray(200.0, 100.0, 200, 100);
        assert!(
            (r.org - Vec3::new(1.0 + 4.0, 2.0 - 2.0, 3.0)).length() < 1e-5,
            "{}",
            r.org
        );
        assert_eq!(r.dir, Vec3::NEG_Z);
    }

    /// `rays` gives `ray`'s rays bit for bit, for both projections and a rotated, scaled,
    /// far-off camera (where the rounding of every operation shows).
    #[test]
    fn batched_rays_equal_single_rays_bit_for_bit() {
        let perspective = Camera {
            name: None,
            projection: Projection::Perspective { yfov: 0.7 },
            to_world: Mat4::from_scale_rotation_translation(
                Vec3::splat(3.7),
                glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.4),
                Vec3::new(1e4, -3.3, 0.25),
            ),
            aspect_ratio: None,
            lens: None,
        };
        let orthographic = Camera {
            projection: Projection::Orthographic { ymag: 1.3 },
            ..perspective.clone()
        };
        let bits = |r: &Ray| {
            [r.org, r.dir]
                .map(|v| v.to_array().map(f32::to_bits))
                .concat()
        };
        for cam in [perspective, orthographic] {
            let g = cam.ray_generator(640, 360);
            let mut next = crate::sampling::hash::uniform_sequence(7);
            for _ in 0..2000 {
                let fx: [f32; 8] = std::array::from_fn(|_| next() * 640.0);
                let fy: [f32; 8] = std::array::from_fn(|_| next() * 360.0);
                let batch = g.rays(&fx, &fy);
                for i in 0..8 {
                    let one = g.ray(fx[i], fy[i]);
                    assert_eq!(bits(&batch[i]), bits(&one), "({}, {})", fx[i], fy[i]);
                }
            }
        }
    }
}
