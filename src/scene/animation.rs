//! glTF animations: the translation, rotation and scale of the nodes an animation targets,
//! sampled at one time (glTF 2.0 §3.11 "Animations", and Appendix C for the interpolation
//! modes). The loader flattens the scene in that pose ([`Pose`]); frames are times
//! `frame / fps`.
//!
//! Before an animation's first key frame a channel holds its first value, after its last key
//! frame its last (the specification leaves this to the implementation; Blender's importer and
//! the Khronos sample viewer clamp alike). Morph target weights are not rendered (strata has no
//! morph targets); the loader says so.

use std::collections::HashMap;

use glam::{DQuat, DVec3};
use gltf::animation::util::ReadOutputs;
use gltf::animation::{Interpolation, Property};

/// Which animation, at what time in seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseTime {
    /// The index of the animation in the document's `animations`.
    pub animation: usize,
    pub seconds: f64,
}

/// The animated parts of the nodes' transforms at one time, by node index; what a channel
/// does not animate keeps the node's own value.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Pose {
    nodes: HashMap<usize, Animated>,
    /// Channels that target morph target weights (not rendered).
    pub weight_channels: usize,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Animated {
    translation: Option<DVec3>,
    rotation: Option<DQuat>,
    scale: Option<DVec3>,
}

impl Pose {
    /// Node `node`'s local transform: its own translation, rotation and scale (decomposed
    /// from its matrix where it has one), each replaced where the pose animates it.
    pub fn local(&self, node: &gltf::Node) -> glam::DMat4 {
        let (t, r, s) = node.transform().decomposed();
        let mut t = DVec3::from_array(t.map(f64::from));
        let mut r = DQuat::from_array(r.map(f64::from));
        let mut s = DVec3::from_array(s.map(f64::from));
        if let Some(a) = self.nodes.get(&node.index()) {
            t = a.translation.unwrap_or(t);
            r = a.rotation.unwrap_or(r);
            s = a.scale.unwrap_or(s);
        }
        glam::DMat4::from_scale_rotation_translation(s, r.normalize(), t)
    }

    /// Whether node `index` is animated.
    pub fn animates(&self, index: usize) -> bool {
        self.nodes.contains_key(&index)
    }
}

/// The pose of `doc`'s animation `at.animation` at `at.seconds`; `buffers` are the
/// document's buffers. Errors name the animation, channel and what is wrong.
pub fn pose(doc: &gltf::Document, buffers: &[Vec<u8>], at: PoseTime) -> Result<Pose, String> {
    let count = doc.animations().len();
    let animation = doc
        .animations()
        .nth(at.animation)
        .ok_or_else(|| match count {
            0 => format!(
                "animation {} asked for, but the file has no animation",
                at.animation
            ),
            n => format!(
                "animation {} asked for, but the file has {n} (0 to {})",
                at.animation,
                n - 1
            ),
        })?;
    if !at.seconds.is_finite() {
        return Err(format!("the time {} s is not finite", at.seconds));
    }
    let mut pose = Pose::default();
    for channel in animation.channels() {
        let label = format!("animation {} channel {}", at.animation, channel.index());
        let reader = channel.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let times: Vec<f32> = reader
            .read_inputs()
            .ok_or_else(|| format!("{label}: its sampler's input cannot be read"))?
            .collect();
        check_times(&times).map_err(|e| format!("{label}: {e}"))?;
        let outputs = reader
            .read_outputs()
            .ok_or_else(|| format!("{label}: its sampler's output cannot be read"))?;
        let mode = channel.sampler().interpolation();
        let node = channel.target().node().index();
        let entry = pose.nodes.entry(node).or_default();
        let t = at.seconds;
        match (channel.target().property(), outputs) {
            (Property::Translation, ReadOutputs::Translations(v)) => {
                let values: Vec<DVec3> = v.map(|a| DVec3::from_array(a.map(f64::from))).collect();
                entry.translation = Some(sample(&times, &values, mode, t, &label, lerp_vec)?);
            }
            (Property::Scale, ReadOutputs::Scales(v)) => {
                let values: Vec<DVec3> = v.map(|a| DVec3::from_array(a.map(f64::from))).collect();
                entry.scale = Some(sample(&times, &values, mode, t, &label, lerp_vec)?);
            }
            (Property::Rotation, ReadOutputs::Rotations(v)) => {
                // Normalised integer rotations are read as floats (KHR_mesh_quantization).
                let values: Vec<DQuat> = v
                    .into_f32()
                    .map(|a| DQuat::from_array(a.map(f64::from)))
                    .collect();
                let q = sample(&times, &values, mode, t, &label, slerp)?;
                if !q.is_finite() || q.length() == 0.0 {
                    return Err(format!("{label}: the rotation at {t} s is not a rotation"));
                }
                entry.rotation = Some(q.normalize());
            }
            (Property::MorphTargetWeights, _) => pose.weight_channels += 1,
            (property, _) => {
                return Err(format!(
                    "{label}: its output does not hold {property:?} values"
                ))
            }
        }
    }
    // A node only weights were animated for has no transform override.
    pose.nodes.retain(|_, a| *a != Animated::default());
    Ok(pose)
}

/// Key frame times must be finite and strictly increasing (glTF 2.0 §3.11).
fn check_times(times: &[f32]) -> Result<(), String> {
    if times.is_empty() {
        return Err("its sampler has no key frame".into());
    }
    if let Some(i) = (0..times.len()).find(|&i| !times[i].is_finite()) {
        return Err(format!("key frame {i}'s time is not finite"));
    }
    if let Some(i) = (1..times.len()).find(|&i| times[i] <= times[i - 1]) {
        return Err(format!(
            "key frame times must increase, but {} s follows {} s (key frame {i})",
            times[i],
            times[i - 1]
        ));
    }
    Ok(())
}

fn lerp_vec(a: DVec3, b: DVec3, s: f64) -> DVec3 {
    a.lerp(b, s)
}

/// Spherical linear interpolation along the shorter arc (glTF 2.0 Appendix C).
fn slerp(a: DQuat, b: DQuat, s: f64) -> DQuat {
    let b = if a.dot(b) < 0.0 { -b } else { b };
    a.normalize().slerp(b.normalize(), s)
}

/// Values a cubic spline can combine (vectors and quaternions as 4-vectors).
trait Spline: Copy {
    fn combine(terms: [(f64, Self); 4]) -> Self;
}

impl Spline for DVec3 {
    fn combine(terms: [(f64, Self); 4]) -> Self {
        terms.iter().map(|&(w, v)| v * w).sum()
    }
}

impl Spline for DQuat {
    fn combine(terms: [(f64, Self); 4]) -> Self {
        let v: glam::DVec4 = terms.iter().map(|&(w, q)| glam::DVec4::from(q) * w).sum();
        DQuat::from_vec4(v)
    }
}

/// The value of a channel with key frames `times` and outputs `values` at time `t`, by its
/// interpolation `mode`; `lerp` is the linear interpolation of its values.
fn sample<T: Spline>(
    times: &[f32],
    values: &[T],
    mode: Interpolation,
    t: f64,
    label: &str,
    lerp: fn(T, T, f64) -> T,
) -> Result<T, String> {
    let n = times.len();
    // CUBICSPLINE stores (in-tangent, value, out-tangent) per key frame.
    let per_key = if mode == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    if values.len() != n * per_key {
        return Err(format!(
            "{label}: {} output values for {n} key frames ({per_key} per key frame expected)",
            values.len()
        ));
    }
    let value = |k: usize| values[k * per_key + per_key / 2];
    // Clamped before the first and after the last key frame.
    if t <= times[0] as f64 {
        return Ok(value(0));
    }
    if t >= times[n - 1] as f64 {
        return Ok(value(n - 1));
    }
    // The key frame interval holding t: times[k] ≤ t < times[k + 1].
    let k = times.partition_point(|&x| (x as f64) <= t) - 1;
    let (t0, t1) = (times[k] as f64, times[k + 1] as f64);
    let td = t1 - t0;
    let s = (t - t0) / td;
    Ok(match mode {
        Interpolation::Step => value(k),
        Interpolation::Linear => lerp(value(k), value(k + 1), s),
        Interpolation::CubicSpline => {
            // Hermite spline (glTF 2.0 Appendix C): the out-tangent b_k of key k and the
            // in-tangent a_{k+1} of key k + 1, both scaled by the interval's length.
            let (s2, s3) = (s * s, s * s * s);
            let b_k = values[3 * k + 2];
            let a_k1 = values[3 * (k + 1)];
            T::combine([
                (2.0 * s3 - 3.0 * s2 + 1.0, value(k)),
                (td * (s3 - 2.0 * s2 + s), b_k),
                (-2.0 * s3 + 3.0 * s2, value(k + 1)),
                (td * (s3 - s2), a_k1),
            ])
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_step_and_cubic_values_between_and_beyond_key_frames() {
        let times = [1.0f32, 3.0];
        let v = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(4.0, 2.0, 0.0)];
        let at = |mode, t| sample(&times, &v, mode, t, "test", lerp_vec).unwrap();
        assert_eq!(at(Interpolation::Linear, 2.0), DVec3::new(2.0, 1.0, 0.0));
        assert_eq!(at(Interpolation::Linear, 2.5), DVec3::new(3.0, 1.5, 0.0));
        assert_eq!(at(Interpolation::Step, 2.9), v[0]);
        assert_eq!(at(Interpolation::Step, 3.0), v[1]);
        // Clamped outside [1, 3].
        assert_eq!(at(Interpolation::Linear, 0.0), v[0]);
        assert_eq!(at(Interpolation::Linear, 10.0), v[1]);

        // A cubic spline with zero tangents eases in and out: 3s² − 2s³ of the way at s.
        let c = [
            DVec3::ZERO,
            v[0],
            DVec3::ZERO,
            DVec3::ZERO,
            v[1],
            DVec3::ZERO,
        ];
        let cubic = |t| sample(&times, &c, Interpolation::CubicSpline, t, "test", lerp_vec);
        let p = cubic(1.5).unwrap(); // s = 1/4: 3/16 − 2/64 = 0.15625
        assert!((p.x - 4.0 * 0.15625).abs() < 1e-12, "{p}");
        // With tangents equal to the secant's slope (2 per second in x), it is the line.
        let slope = DVec3::new(2.0, 1.0, 0.0);
        let c = [slope, v[0], slope, slope, v[1], slope];
        let p = sample(&times, &c, Interpolation::CubicSpline, 2.5, "t", lerp_vec).unwrap();
        assert!((p - DVec3::new(3.0, 1.5, 0.0)).length() < 1e-12, "{p}");
        // Wrong counts are refused.
        assert!(sample(&times, &v, Interpolation::CubicSpline, 2.0, "t", lerp_vec).is_err());
    }

    #[test]
    fn rotations_take_the_shorter_arc() {
        let a = DQuat::from_rotation_y(0.0);
        // The same rotation by 90° about y, written with the opposite sign.
        let b = -DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2);
        let q = slerp(a, b, 0.5);
        let want = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4);
        assert!(q.dot(want).abs() > 1.0 - 1e-12, "{q} against {want}");
    }

    #[test]
    fn key_frame_times_must_increase() {
        assert!(check_times(&[0.0, 1.0, 2.0]).is_ok());
        assert!(check_times(&[0.0, 1.0, 1.0]).is_err());
        assert!(check_times(&[0.0, f32::NAN]).is_err());
        assert!(check_times(&[]).is_err());
    }
}
