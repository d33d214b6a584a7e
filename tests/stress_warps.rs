//! Stress properties of the warps (src/sampling/warps.rs) and the orthonormal basis
//! (src/sampling/onb.rs), checked with proptest over inputs that include the edges of the
//! unit square: exactly 0, exactly 1, the largest f32 below 1 (1 − ε/2), 0.5 (the centre of
//! the concentric map) and the diagonals (the wedge boundaries of the concentric map).
//!
//! Each warp must give a finite result in its domain (directions of unit length to 1e-5) and
//! a finite, positive pdf (one documented exception: the cosine warp's rim, see
//! `check_cosine_hemisphere`); each inverse map must give finite values in [0, 1]. Onb
//! frames must be orthonormal to 1e-6 and right-handed for any unit normal, including the
//! axes, signed zeros, denormal components and normals within 1e-7 of −z.
//!
//! The checks are plain functions returning `Result`, so the negative controls at the end run
//! the same checks, through the same strategies, against broken versions and require proptest
//! to find the failure: the concentric map without its centre guard, the inverse triangle map
//! without its guard at s = 0, Frisvad's original ONB, and the three warps as they were
//! before this suite found their faults (cone, triangle, spherical triangle).
//!
//! `PROPTEST_CASES=N` raises the number of cases per property for a soak run.

use std::f32::consts::{FRAC_1_PI, TAU};

use glam::{Vec2, Vec3};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use strata::sampling::onb::Onb;
use strata::sampling::warps::*;

/// The largest f32 below 1.
const BELOW_ONE: f32 = 1.0 - f32::EPSILON / 2.0;

const UNIT_TOL: f32 = 1e-5;

/// `cases` per property, or `PROPTEST_CASES` when set (for longer soak runs).
fn config(cases: u32) -> Config {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(cases);
    Config {
        cases,
        // The spherical-triangle strategy filters out ~6% of its draws.
        max_local_rejects: cases.max(65_536),
        // Edge values found failing are kept as explicit `Just` cases in the strategies
        // instead of a regressions file.
        failure_persistence: None,
        ..Config::default()
    }
}

// ---------------------------------------------------------------------------------------
// Strategies
// ---------------------------------------------------------------------------------------

/// A number in [0, 1], drawn often at the edges.
fn unit_interval() -> impl Strategy<Value = f32> + Clone {
    prop_oneof![
        1 => Just(0.0f32),
        1 => Just(1.0f32),
        1 => Just(BELOW_ONE),
        1 => Just(0.5f32),
        1 => Just(f32::EPSILON / 2.0),
        1 => Just(f32::from_bits(1)),
        6 => 0.0f32..=1.0,
    ]
}

/// A point of [0, 1]², sometimes on a diagonal.
fn square() -> impl Strategy<Value = Vec2> + Clone {
    let u = unit_interval();
    prop_oneof![
        4 => (u.clone(), u.clone()).prop_map(|(x, y)| Vec2::new(x, y)),
        1 => u.clone().prop_map(|x| Vec2::new(x, x)),
        1 => u.prop_map(|x| Vec2::new(x, 1.0 - x)),
    ]
}

/// cos θmax of a cone, in (−1, 1), with the extremes.
fn cone_cos_max() -> impl Strategy<Value = f32> + Clone {
    prop_oneof![
        1 => Just(-1.0 + f32::EPSILON),
        1 => Just(BELOW_ONE),
        1 => Just(0.0f32),
        1 => Just(-0.0f32),
        1 => Just(0.999_999),
        6 => (-1.0f32..1.0).prop_filter("open interval", |c| *c > -1.0),
    ]
}

/// A unit vector: random directions, the axes with either sign of zero, and vectors one ulp
/// away from the poles.
fn unit_vector() -> impl Strategy<Value = Vec3> + Clone {
    let axes: Vec<Vec3> = vec![
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
        Vec3::new(-0.0, -0.0, 1.0),
        Vec3::new(-0.0, 0.0, -1.0),
        Vec3::new(1.0, -0.0, -0.0),
        Vec3::new(-0.0, -1.0, -0.0),
    ];
    prop_oneof![
        1 => proptest::sample::select(axes),
        4 => (-1.0f32..=1.0, -1.0f32..=1.0, -1.0f32..=1.0)
            .prop_filter_map("too short to normalise", |(x, y, z)| {
                let v = Vec3::new(x, y, z);
                (v.length_squared() > 1e-6).then(|| v.normalize())
            }),
    ]
}

/// Unit vectors for the inverse maps: [`unit_vector`], and directions on or next to the
/// rim z = 0, whose (x, y) part, normalised in f32, can be a rounding error longer than 1.
fn any_direction() -> impl Strategy<Value = Vec3> {
    let rim = (
        0.0f32..TAU,
        prop::sample::select(vec![0.0f32, -0.0, 1e-7, 1e-30]),
    )
        .prop_map(|(phi, z)| Vec3::new(phi.cos(), phi.sin(), z).normalize());
    prop_oneof![
        // Found by proptest: concentric_disk_to_square gave x = −6e-8 before its clamp.
        1 => Just(Vec3::new(-0.904_214_5, 0.427_078_78, 0.0)),
        4 => rim,
        8 => unit_vector(),
    ]
}

/// Unit normals for the ONB: random directions plus the cases that break naive frames.
fn onb_normal() -> impl Strategy<Value = Vec3> {
    // Within 1e-7 of −z (and of +z): tiny tangential parts, normalised.
    let near_pole = (-1.0f32..=1.0, -1.0f32..=1.0, prop::bool::ANY).prop_map(|(a, b, up)| {
        let z = if up { 1.0 } else { -1.0 };
        Vec3::new(a * 1e-7, b * 1e-7, z).normalize()
    });
    // Denormal components, normalised.
    let denormal = (
        prop::sample::select(vec![1e-40f32, -1e-40, 1e-45, f32::MIN_POSITIVE / 2.0]),
        0usize..3,
        prop::bool::ANY,
    )
        .prop_map(|(tiny, axis, neg)| {
            let mut v = [0.0f32; 3];
            v[axis] = tiny;
            v[(axis + 2) % 3] = if neg { -1.0 } else { 1.0 };
            Vec3::from_array(v).normalize()
        });
    // One ulp from z = −1: the largest |x| that still keeps the vector unit.
    let z = -BELOW_ONE;
    let r = (1.0 - z * z).sqrt();
    let special = vec![
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
        Vec3::new(-0.0, -0.0, -1.0),
        Vec3::new(0.0, -0.0, -1.0),
        Vec3::new(-0.0, -0.0, 1.0),
        Vec3::new(1.0, 0.0, -0.0),
        Vec3::new(-1.0, -0.0, -0.0),
        Vec3::new(0.0, -1.0, -0.0),
        Vec3::new(0.6, -0.8, -0.0),
        Vec3::new(1e-40, 0.0, 1.0).normalize(),
        Vec3::new(r, 0.0, z),
        Vec3::new(0.0, -r, z),
    ];
    prop_oneof![
        2 => proptest::sample::select(special),
        2 => near_pole,
        1 => denormal,
        4 => unit_vector(),
    ]
}

/// A spherical triangle of unit vectors whose solid angle lies where lights.rs samples by
/// solid angle (3e-4 ≤ Ω ≤ 6.22 sr, pbrt-v4's bounds): random triangles; small ones around
/// a random centre; needles (two vertices close together, one far); slivers (three
/// vertices near one great circle).
fn spherical_triangle() -> impl Strategy<Value = [Vec3; 3]> {
    let offset = || (-1.0f32..=1.0, -1.0f32..=1.0, -1.0f32..=1.0);
    let v3 = |(x, y, z): (f32, f32, f32)| Vec3::new(x, y, z);
    let random = (unit_vector(), unit_vector(), unit_vector()).prop_map(|(a, b, c)| [a, b, c]);
    let small = (
        unit_vector(),
        prop::array::uniform3(offset()),
        0.005f32..0.5,
    )
        .prop_map(move |(centre, offsets, size)| {
            offsets.map(|o| (centre + size * v3(o)).normalize_or_zero())
        });
    let needle = (
        unit_vector(),
        unit_vector(),
        offset(),
        1e-3f32..0.1,
        0usize..3,
    )
        .prop_map(move |(a, far, o, size, rotate)| {
            let mut t = [a, (a + size * v3(o)).normalize_or_zero(), far];
            t.rotate_left(rotate);
            t
        });
    let sliver = (
        unit_vector(),
        unit_vector(),
        offset(),
        0.0f32..=1.0,
        1e-3f32..0.05,
    )
        .prop_map(move |(a, c, o, along, size)| {
            let b = (a + along * (c - a) + size * v3(o)).normalize_or_zero();
            [a, b, c]
        });
    prop_oneof![random, small, needle, sliver].prop_filter(
        "outside the solid-angle sampling range",
        |t| {
            t.iter().all(|v| v.is_normalized())
                && (3e-4..=6.22).contains(&spherical_triangle_area(t[0], t[1], t[2]))
        },
    )
}

// ---------------------------------------------------------------------------------------
// Checks
// ---------------------------------------------------------------------------------------

fn check_unit(name: &str, u: Vec2, v: Vec3) -> Result<(), String> {
    if !v.is_finite() {
        return Err(format!("{name}({u}) = {v} is not finite"));
    }
    if (v.length() - 1.0).abs() > UNIT_TOL {
        return Err(format!("{name}({u}) = {v} has length {}", v.length()));
    }
    Ok(())
}

fn check_pdf(name: &str, u: Vec2, pdf: f32) -> Result<(), String> {
    if pdf.is_finite() && pdf > 0.0 {
        Ok(())
    } else {
        Err(format!("{name}({u}): pdf {pdf}"))
    }
}

/// An inverse map's output: finite and in [0, 1]².
fn check_square(name: &str, input: impl std::fmt::Display, s: Vec2) -> Result<(), String> {
    let inside = |x: f32| (0.0..=1.0).contains(&x);
    if s.is_finite() && inside(s.x) && inside(s.y) {
        Ok(())
    } else {
        Err(format!("{name}({input}) = {s}, not in [0, 1]²"))
    }
}

fn check_uniform_hemisphere(u: Vec2) -> Result<(), String> {
    let v = square_to_uniform_hemisphere(u);
    check_unit("uniform hemisphere", u, v)?;
    if v.z < 0.0 {
        return Err(format!("uniform hemisphere({u}) = {v} below z = 0"));
    }
    check_pdf("uniform hemisphere", u, uniform_hemisphere_pdf(v))?;
    check_square(
        "uniform_hemisphere_to_square",
        v,
        uniform_hemisphere_to_square(v),
    )
}

/// Distance from `u` to the nearest edge of the unit square.
fn distance_to_square_edge(u: Vec2) -> f32 {
    u.x.min(1.0 - u.x).min(u.y).min(1.0 - u.y)
}

/// The cosine-weighted density is cos θ / π, which is 0 at the rim z = 0. The concentric
/// map sends the boundary of the square to the rim, and in f32 also points within about
/// 2⁻²⁴ of it (2u − 1 rounds to ±1, or 1 − |d|² to 0). There the pdf is 0 by definition,
/// not by a bug: a positive value would be wrong for the MIS weights that evaluate the same
/// pdf. Such samples must be rejected by whoever divides by the pdf;
/// `lambertian_rejects_rim_samples` checks that `Lambertian::sample` does (AO weights cosine
/// samples by 1 and never divides). Everywhere else the pdf must be positive.
fn check_cosine_hemisphere(u: Vec2) -> Result<(), String> {
    let v = square_to_cosine_hemisphere(u);
    check_unit("cosine hemisphere", u, v)?;
    if v.z < 0.0 {
        return Err(format!("cosine hemisphere({u}) = {v} below z = 0"));
    }
    let pdf = cosine_hemisphere_pdf(v);
    if !(pdf.is_finite() && pdf >= 0.0) {
        return Err(format!("cosine hemisphere({u}): pdf {pdf}"));
    }
    // Rounding reaches the rim from u = 2⁻²⁴ (seen); allow twice that.
    if pdf == 0.0 && distance_to_square_edge(u) > f32::EPSILON {
        return Err(format!(
            "cosine hemisphere({u}) = {v}: pdf 0 {} from the square's edge",
            distance_to_square_edge(u)
        ));
    }
    if (pdf - v.z * FRAC_1_PI).abs() > 1e-6 {
        return Err(format!("cosine hemisphere({u}): pdf {pdf} ≠ cos θ/π"));
    }
    check_square(
        "cosine_hemisphere_to_square",
        v,
        cosine_hemisphere_to_square(v),
    )
}

fn check_concentric_disk(
    u: Vec2,
    to_disk: fn(Vec2) -> Vec2,
    to_square: fn(Vec2) -> Vec2,
) -> Result<(), String> {
    let d = to_disk(u);
    if !d.is_finite() || d.length() > 1.0 + 1e-6 {
        return Err(format!("concentric disk({u}) = {d} not in the unit disk"));
    }
    check_square("concentric_disk_to_square", d, to_square(d))
}

fn check_uniform_sphere(u: Vec2) -> Result<(), String> {
    let v = square_to_uniform_sphere(u);
    check_unit("uniform sphere", u, v)?;
    check_pdf("uniform sphere", u, uniform_sphere_pdf())?;
    check_square("uniform_sphere_to_square", v, uniform_sphere_to_square(v))
}

fn check_uniform_cone(u: Vec2, cos_max: f32, warp: fn(Vec2, f32) -> Vec3) -> Result<(), String> {
    let name = format!("uniform cone cos θmax = {cos_max}");
    let v = warp(u, cos_max);
    check_unit(&name, u, v)?;
    if v.z < cos_max {
        return Err(format!("{name}({u}) = {v} outside the cone"));
    }
    check_pdf(&name, u, uniform_cone_pdf(v, cos_max))?;
    check_square(&name, v, uniform_cone_to_square(v, cos_max))
}

fn check_uniform_triangle(
    u: Vec2,
    warp: fn(Vec2) -> Vec2,
    to_square: fn(Vec2) -> Vec2,
) -> Result<(), String> {
    let b = warp(u);
    let b2 = 1.0 - b.x - b.y;
    if !b.is_finite() || b.x < 0.0 || b.y < 0.0 || b2 < 0.0 || b.x + b.y > 1.0 {
        return Err(format!(
            "uniform triangle({u}) = ({}, {}, {b2}) outside the triangle",
            b.x, b.y
        ));
    }
    // The pdf is 1/area: positive and finite for any triangle of positive finite area, so
    // the barycentrics map to a point inside a concrete triangle.
    let [p0, p1, p2] = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(3.0, 0.0, 1.0),
        Vec3::new(0.0, 2.0, 0.0),
    ];
    let p = b.x * p0 + b.y * p1 + b2 * p2;
    let area = 0.5 * (p1 - p0).cross(p2 - p0).length();
    check_pdf("uniform triangle", u, 1.0 / area)?;
    if !p.is_finite() {
        return Err(format!("uniform triangle({u}): point {p}"));
    }
    check_square("uniform_triangle_to_square", b, to_square(b))
}

/// How far (radians) a sample may lie outside its spherical triangle. Arvo's original solve
/// for Ĉ put samples up to ~1e-2 outside thin triangles of 1e-3 sr.
const SPHERICAL_TOL: f64 = 2e-5;

/// How far `p` lies outside triangle (a, b, c): the largest distance beyond one of the
/// three great circles through its edges, 0 or negative inside. Computed in f64 from the
/// f32 inputs: in f32, the plane of a short edge (vertices 5e-4 apart) is itself uncertain
/// by ~1e-4 rad, which would blame the sampler for the checker's rounding.
fn outside_spherical_triangle(p: Vec3, tri: [Vec3; 3]) -> f64 {
    let [p, a, b, c] = [p, tri[0], tri[1], tri[2]].map(|v| v.as_dvec3());
    let orientation = a.dot(b.cross(c)).signum();
    [(a, b), (b, c), (c, a)]
        .iter()
        .map(|&(x, y)| -p.dot(x.cross(y).normalize_or_zero() * orientation))
        .fold(f64::MIN, f64::max)
}

type SphericalWarp = fn(Vec3, Vec3, Vec3, Vec2) -> Option<Vec3>;

fn check_spherical_triangle(tri: [Vec3; 3], u: Vec2, warp: SphericalWarp) -> Result<(), String> {
    let [a, b, c] = tri;
    let name = format!("spherical triangle {tri:?}");
    let Some(w) = warp(a, b, c, u) else {
        return Err(format!("{name}({u}): None for a non-degenerate triangle"));
    };
    check_unit(&name, u, w)?;
    let outside = outside_spherical_triangle(w, tri);
    if outside > SPHERICAL_TOL {
        return Err(format!(
            "{name}({u}) = {w} {outside:e} rad outside the triangle"
        ));
    }
    check_pdf(&name, u, 1.0 / spherical_triangle_area(a, b, c))
}

fn check_onb(n: Vec3, v: Vec3, from_normal: fn(Vec3) -> Onb) -> Result<(), String> {
    let f = from_normal(n);
    let tol = 1e-6;
    if !(f.t.is_finite() && f.b.is_finite() && f.n.is_finite()) {
        return Err(format!("frame of {n} is not finite: {f:?}"));
    }
    for (name, x) in [("|t|", f.t.length()), ("|b|", f.b.length())] {
        if (x - 1.0).abs() > tol {
            return Err(format!("frame of {n}: {name} = {x}"));
        }
    }
    for (name, x) in [
        ("t·b", f.t.dot(f.b)),
        ("t·n", f.t.dot(f.n)),
        ("b·n", f.b.dot(f.n)),
    ] {
        if x.abs() > tol {
            return Err(format!("frame of {n}: {name} = {x}"));
        }
    }
    if (f.t.cross(f.b) - n).abs().max_element() > tol {
        return Err(format!(
            "frame of {n} is not right-handed: t × b = {}",
            f.t.cross(f.b)
        ));
    }
    let back = f.to_world(f.to_local(v));
    if !back.is_finite() || (back - v).abs().max_element() > 1e-5 {
        return Err(format!("frame of {n}: to_world(to_local({v})) = {back}"));
    }
    Ok(())
}

/// Runs a check as a proptest case.
fn case(r: Result<(), String>) -> Result<(), TestCaseError> {
    r.map_err(TestCaseError::fail)
}

// ---------------------------------------------------------------------------------------
// Properties of the shipped code
// ---------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(config(4096))]

    #[test]
    fn uniform_hemisphere_is_finite_unit_and_upper(u in square()) {
        case(check_uniform_hemisphere(u))?;
    }

    #[test]
    fn cosine_hemisphere_is_finite_unit_and_upper(u in square()) {
        case(check_cosine_hemisphere(u))?;
    }

    #[test]
    fn concentric_disk_stays_in_the_disk(u in square()) {
        case(check_concentric_disk(u, square_to_concentric_disk, concentric_disk_to_square))?;
    }

    #[test]
    fn uniform_sphere_is_finite_and_unit(u in square()) {
        case(check_uniform_sphere(u))?;
    }

    #[test]
    fn uniform_cone_stays_in_its_cone(u in square(), cos_max in cone_cos_max()) {
        case(check_uniform_cone(u, cos_max, square_to_uniform_cone))?;
    }

    #[test]
    fn uniform_triangle_stays_in_the_triangle(u in square()) {
        case(check_uniform_triangle(u, square_to_uniform_triangle, uniform_triangle_to_square))?;
    }

    #[test]
    fn spherical_triangle_samples_stay_in_the_triangle(
        tri in spherical_triangle(),
        u in square(),
    ) {
        case(check_spherical_triangle(tri, u, square_to_spherical_triangle))?;
    }

    /// Any three unit vectors, degenerate ones included (coincident, collinear on a great
    /// circle, antipodal): the result is `None` or a finite unit vector, never NaN.
    #[test]
    fn spherical_triangle_never_returns_nan(
        a in unit_vector(),
        b in unit_vector(),
        c in unit_vector(),
        pick in 0usize..4,
        u in square(),
    ) {
        // Make a degenerate triangle half of the time.
        let (b, c) = match pick {
            0 => (a, c),
            1 => (b, -b),
            _ => (b, c),
        };
        if let Some(w) = square_to_spherical_triangle(a, b, c, u) {
            case(check_unit("spherical triangle", u, w))?;
        }
    }

    /// Inverse maps of directions that did not come from the forward maps.
    #[test]
    fn inverse_maps_stay_in_the_square(v in any_direction(), cos_max in cone_cos_max()) {
        let upper = Vec3::new(v.x, v.y, v.z.abs());
        case(check_square("uniform_hemisphere_to_square", upper, uniform_hemisphere_to_square(upper)))?;
        case(check_square("cosine_hemisphere_to_square", upper, cosine_hemisphere_to_square(upper)))?;
        case(check_square("uniform_sphere_to_square", v, uniform_sphere_to_square(v)))?;
        let disk = Vec2::new(v.x, v.y);
        case(check_square("concentric_disk_to_square", disk, concentric_disk_to_square(disk)))?;
        if v.z >= cos_max {
            case(check_square("uniform_cone_to_square", v, uniform_cone_to_square(v, cos_max)))?;
        }
    }

    #[test]
    fn onb_is_orthonormal_right_handed_and_invertible(
        n in onb_normal(),
        v in (-1.0f32..=1.0, -1.0f32..=1.0, -1.0f32..=1.0),
    ) {
        case(check_onb(n, Vec3::new(v.0, v.1, v.2), Onb::from_normal))?;
    }
}

#[test]
fn largest_f32_below_one_is_one_minus_half_epsilon() {
    // The brief lists both; they are the same number, so the strategy holds it once.
    assert_eq!(BELOW_ONE, f32::from_bits(1.0f32.to_bits() - 1));
}

/// Every listed edge input, checked exhaustively (no randomness): all pairs of edge values.
#[test]
fn edge_values_exhaustively() {
    let edges = [
        0.0,
        f32::from_bits(1),
        f32::EPSILON / 2.0,
        0.25,
        0.5,
        0.75,
        BELOW_ONE,
        1.0,
    ];
    let mut failures = Vec::new();
    for &x in &edges {
        for &y in &edges {
            let u = Vec2::new(x, y);
            let mut results = vec![
                check_uniform_hemisphere(u),
                check_cosine_hemisphere(u),
                check_concentric_disk(u, square_to_concentric_disk, concentric_disk_to_square),
                check_uniform_sphere(u),
                check_uniform_triangle(u, square_to_uniform_triangle, uniform_triangle_to_square),
                check_spherical_triangle(
                    [Vec3::X, Vec3::Y, Vec3::Z],
                    u,
                    square_to_spherical_triangle,
                ),
            ];
            for c in [-1.0 + f32::EPSILON, -0.5, 0.0, 0.3, 0.999_999, BELOW_ONE] {
                results.push(check_uniform_cone(u, c, square_to_uniform_cone));
            }
            failures.extend(results.into_iter().filter_map(Result::err));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The grazing rim of the cosine warp (pdf 0, see `check_cosine_hemisphere`) never reaches
/// an estimator: the diffuse BSDF's `sample` returns `None` there instead of a zero pdf.
#[test]
fn lambertian_rejects_rim_samples() {
    use strata::shading::interaction::SurfaceInteraction;
    use strata::shading::{Bsdf, Lambertian, SurfaceBsdf};
    let edges = [0.0, 0.3, 0.5, BELOW_ONE, 1.0];
    for n in [Vec3::Z, Vec3::NEG_Z, Vec3::new(0.6, 0.0, 0.8)] {
        let si = SurfaceInteraction {
            p: Vec3::ZERO,
            p_error: Vec3::ZERO,
            ng: n,
            ns: n,
            wo: n,
            front_face: true,
            prim: 0,
            inst: strata::ray::NO_INSTANCE,
            u: 0.0,
            v: 0.0,
        };
        let bsdf = SurfaceBsdf::new(Bsdf::Diffuse(Lambertian::new(Vec3::splat(0.5))), &si);
        for &x in &edges {
            for &y in &edges {
                let u = Vec2::new(x, y);
                if let Some(s) = bsdf.sample(0.0, u) {
                    let (wi, pdf) = (s.wi, s.pdf);
                    assert!(
                        pdf.is_finite() && pdf > 0.0 && wi.is_finite(),
                        "n {n}, u {u}: wi {wi}, pdf {pdf}"
                    );
                    let w = s.f_cos / pdf;
                    assert!(w.is_finite(), "n {n}, u {u}: weight {w}");
                } else {
                    // Only rim samples (or those below the geometric surface) are dropped.
                    let local = square_to_cosine_hemisphere(u);
                    assert!(
                        local.z <= 1e-3,
                        "n {n}, u {u}: sample {local} dropped although above the rim"
                    );
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Negative controls: the same checks through the same strategies find known bugs.
// ---------------------------------------------------------------------------------------

/// Runs `check` on `strategy` and returns whether proptest found a failing input.
fn finds_failure<S: Strategy>(
    strategy: S,
    check: impl Fn(S::Value) -> Result<(), String>,
) -> Option<String> {
    let mut runner = TestRunner::new(config(4096));
    match runner.run(&strategy, |v| case(check(v))) {
        Ok(()) => None,
        Err(e) => Some(e.to_string()),
    }
}

/// The concentric map without its guard at the centre divides 0 by 0 at u = (0.5, 0.5).
fn concentric_disk_without_centre_guard(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (
            o.y,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y),
        )
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// The inverse triangle map without its guard divides 0 by 0 when b0 = 1 (u.x = 0).
fn uniform_triangle_to_square_without_guard(b: Vec2) -> Vec2 {
    let s = 1.0 - b.x;
    Vec2::new(s * s, b.y / s)
}

/// Frisvad's 2012 frame: 1/(1 + n.z) is infinite at n = −z and loses all precision near it.
fn frisvad(n: Vec3) -> Onb {
    let a = 1.0 / (1.0 + n.z);
    let b = -n.x * n.y * a;
    Onb {
        t: Vec3::new(1.0 - n.x * n.x * a, b, -n.x),
        b: Vec3::new(b, 1.0 - n.y * n.y * a, -n.y),
        n,
    }
}

/// The cone warp before its clamp: 1 − u·(1 − cos θmax) rounds below cos θmax.
fn cone_without_clamp(u: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// The triangle warp before its bound on b1: b2 = 1 − b0 − b1 < 0 for tiny u.x.
fn triangle_without_bound(u: Vec2) -> Vec2 {
    let s = u.x.sqrt();
    Vec2::new(1.0 - s, u.y * s)
}

/// Arvo's closed form for Ĉ through the vertex angle α (acos of the dot product of the edge
/// planes' normals), as strata had it before this suite: in f32 it loses most digits on thin
/// triangles.
fn spherical_triangle_through_alpha(a: Vec3, b: Vec3, c: Vec3, u: Vec2) -> Option<Vec3> {
    let area = spherical_triangle_area(a, b, c);
    if !(area > 0.0 && area.is_finite()) {
        return None;
    }
    let cos_alpha = a
        .cross(b)
        .try_normalize()?
        .dot(a.cross(c).try_normalize()?)
        .clamp(-1.0, 1.0);
    let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
    let (s, t) = (u.x * area - cos_alpha.acos()).sin_cos();
    let p = t - cos_alpha;
    let q = s + sin_alpha * a.dot(b);
    let den = (q * s + p * t) * sin_alpha;
    let cos_b = if den != 0.0 {
        (((q * t - p * s) * cos_alpha - q) / den).clamp(-1.0, 1.0)
    } else {
        1.0
    };
    let c_hat =
        cos_b * a + (1.0 - cos_b * cos_b).max(0.0).sqrt() * (c - c.dot(a) * a).try_normalize()?;
    let z = 1.0 - u.y * (1.0 - c_hat.dot(b));
    let Some(perp) = (c_hat - c_hat.dot(b) * b).try_normalize() else {
        return Some(b);
    };
    Some((z * b + (1.0 - z * z).max(0.0).sqrt() * perp).normalize())
}

#[test]
fn negative_control_cone_without_clamp() {
    let found = finds_failure((square(), cone_cos_max()), |(u, c)| {
        check_uniform_cone(u, c, cone_without_clamp)
    });
    assert!(found.is_some(), "no rounding below cos θmax found");
}

#[test]
fn negative_control_triangle_without_bound() {
    let found = finds_failure(square(), |u| {
        check_uniform_triangle(u, triangle_without_bound, uniform_triangle_to_square)
    });
    assert!(found.is_some(), "no negative b2 found");
}

#[test]
fn negative_control_spherical_triangle_through_alpha() {
    let found = finds_failure((spherical_triangle(), square()), |(tri, u)| {
        check_spherical_triangle(tri, u, spherical_triangle_through_alpha)
    });
    assert!(found.is_some(), "the old solve for Ĉ passed");
}

#[test]
fn negative_control_concentric_centre() {
    let found = finds_failure(square(), |u| {
        check_concentric_disk(
            u,
            concentric_disk_without_centre_guard,
            concentric_disk_to_square,
        )
    });
    assert!(found.is_some(), "the strategy never reached u = (0.5, 0.5)");
}

#[test]
fn negative_control_inverse_triangle_at_a_vertex() {
    let found = finds_failure(square(), |u| {
        check_uniform_triangle(
            u,
            square_to_uniform_triangle,
            uniform_triangle_to_square_without_guard,
        )
    });
    assert!(found.is_some(), "the strategy never reached u.x = 0");
}

#[test]
fn negative_control_frisvad_frame_near_minus_z() {
    let found = finds_failure(
        (onb_normal(), (-1.0f32..=1.0, -1.0f32..=1.0, -1.0f32..=1.0)),
        |(n, v)| check_onb(n, Vec3::new(v.0, v.1, v.2), frisvad),
    );
    assert!(
        found.is_some(),
        "Frisvad's frame passed: the normals never came near −z"
    );
}

/// Sanity of the checks themselves on hand-made bad values.
#[test]
fn checks_reject_bad_values() {
    let u = Vec2::ZERO;
    assert!(check_unit("x", u, Vec3::new(f32::NAN, 0.0, 1.0)).is_err());
    assert!(check_unit("x", u, Vec3::new(0.0, 0.0, 1.0001)).is_err());
    assert!(check_pdf("x", u, 0.0).is_err());
    assert!(check_pdf("x", u, f32::INFINITY).is_err());
    assert!(check_square("x", 0, Vec2::new(1.0000001, 0.5)).is_err());
    assert!(check_square("x", 0, Vec2::new(-1e-9, 0.5)).is_err());
    let octant = [Vec3::X, Vec3::Y, Vec3::Z];
    assert!(outside_spherical_triangle(-Vec3::ONE.normalize(), octant) > 0.5);
    assert!(outside_spherical_triangle(Vec3::ONE.normalize(), octant) < 0.0);
}
