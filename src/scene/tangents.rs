//! Tangent frames for normal maps, one per triangle corner.
//!
//! glTF 2.0 ("Meshes", "Materials: normalTexture"): the tangent space's +X is `TANGENT.xyz`,
//! +Y the bitangent `cross(NORMAL, TANGENT.xyz) × TANGENT.w` (w = ±1, the handedness), +Z the
//! normal; when a primitive with a normal map has no `TANGENT`, tangents are computed "using
//! default MikkTSpace algorithms with the specified vertex positions, normals, and texture
//! coordinates associated with the normal texture". strata does so with `bevy_mikktspace`
//! (a safe Rust port, byte-identical to Mikkelsen's reference code), per primitive, in world
//! space. MikkTSpace may give one vertex different tangents in different triangles (at UV
//! seams and mirrored UVs), so frames are kept per triangle corner rather than per vertex.
//! Either way the bitangent cross(n, t) w points up the image (toward decreasing v), where a
//! normal map's +Y (green) points.

use glam::{DMat3, Vec3, Vec4};

use super::Scene;

/// The triangles of one primitive, by their vertices in the scene.
struct Primitive<'a> {
    scene: &'a Scene,
    corners: &'a [[u32; 3]],
    out: Vec<[Vec4; 3]>,
}

impl Primitive<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.corners[face][vert] as usize
    }
}

impl bevy_mikktspace::Geometry for Primitive<'_> {
    fn num_faces(&self) -> usize {
        self.corners.len()
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.scene.positions[self.vertex(face, vert)].to_array()
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        let n = self.scene.normals[self.vertex(face, vert)];
        if n != Vec3::ZERO {
            return n.to_array();
        }
        // A flat-shaded corner: the face's normal (counter-clockwise winding).
        let [a, b, c] = self.corners[face].map(|i| self.scene.positions[i as usize]);
        (b - a).cross(c - a).normalize_or_zero().to_array()
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.scene.uvs[self.vertex(face, vert)].to_array()
    }

    fn set_tangent(
        &mut self,
        tangent_space: Option<bevy_mikktspace::TangentSpace>,
        face: usize,
        vert: usize,
    ) {
        // MikkTSpace's bitangent runs toward increasing v; glTF's v runs down the image while
        // a normal map's +Y is up (OpenGL's convention, which glTF's TANGENT.w encodes), so
        // the sign is negated, as three.js does for glTF (`computeMikkTSpaceTangents`'s
        // `negateSign`) and as flipping v before MikkTSpace would.
        self.out[face][vert] = match tangent_space {
            Some(t) => {
                let [x, y, z, w] = t.tangent_encoded();
                Vec4::new(x, y, z, -w)
            }
            None => Vec4::ZERO,
        };
    }
}

/// MikkTSpace tangents (xyz, and the bitangent's sign in w) of the triangles `corners` of one
/// primitive, whose positions, normals and TEXCOORD_0 are in `scene`; a corner it gives no
/// frame is zero.
pub(crate) fn mikktspace(scene: &Scene, corners: &[[u32; 3]]) -> Vec<[Vec4; 3]> {
    let mut primitive = Primitive {
        scene,
        corners,
        out: vec![[Vec4::ZERO; 3]; corners.len()],
    };
    // The crate's error type has no variants: generation cannot fail.
    let _ = bevy_mikktspace::generate_tangents(&mut primitive);
    primitive.out
}

/// Adds to `scene` the tangent frames of the triangles from `first` on (those this primitive added, whose
/// file vertices are `corners`: empty unless its material has a normal map): from the
/// file's `TANGENT` (`file`: the primitive's first vertex in the scene and its tangents in
/// object space: xyz by the node's `linear` map, w negated under a mirroring one) or else
/// by MikkTSpace (later: [`super::Scene::tangent_frames`]).
pub(super) fn add_frames(
    scene: &mut Scene,
    first: usize,
    corners: &[[u32; 3]],
    file: Option<(usize, &[[f32; 4]])>,
    linear: &DMat3,
    flip: bool,
) {
    let added = scene.triangles.len() - first;
    if corners.is_empty() {
        if !scene.tangents.is_empty() {
            scene
                .tangents
                .extend(std::iter::repeat_n([Vec4::ZERO; 3], added));
        }
        return;
    }
    let frames: Vec<[Vec4; 3]> = match file {
        Some((base, ts)) => {
            // Once per vertex, then looked up per corner.
            let m = linear.as_mat3();
            let sign = if flip { -1.0 } else { 1.0 };
            let world: Vec<Vec4> = ts
                .iter()
                .map(|t| {
                    let xyz = (m * Vec3::new(t[0], t[1], t[2])).normalize_or_zero();
                    let w = if t[3] < 0.0 { -sign } else { sign };
                    match xyz.is_finite() && xyz != Vec3::ZERO {
                        true => xyz.extend(w),
                        false => Vec4::ZERO,
                    }
                })
                .collect();
            corners
                .iter()
                .map(|c| c.map(|i| world[i as usize - base]))
                .collect()
        }
        None => {
            // MikkTSpace waits until a render reads the normal map (ambient occlusion
            // does not): the frames stay zero, and the primitive's corners are kept.
            scene.pending_tangents.push(super::PendingTangents {
                first_triangle: first,
                corners: corners.to_vec(),
            });
            vec![[Vec4::ZERO; 3]; corners.len()]
        }
    };
    if scene.tangents.is_empty() {
        scene.tangents = vec![[Vec4::ZERO; 3]; first];
    }
    scene.tangents.extend(frames);
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    /// A quad in the xy plane facing +z, its image upright (u along +x, glTF's v down the
    /// image, along −y): the tangent is +x and the bitangent cross(n, t) w is +y, up the image.
    /// Its mirror image (u along −x) gets the tangent −x and still the bitangent +y.
    #[test]
    fn a_quad_gets_the_u_direction_as_its_tangent() {
        for (mirror, expect) in [(1.0f32, Vec3::X), (-1.0, Vec3::NEG_X)] {
            let scene = Scene {
                positions: vec![
                    Vec3::new(0.0, 0.0, 0.0),
                    Vec3::new(1.0, 0.0, 0.0),
                    Vec3::new(1.0, 1.0, 0.0),
                    Vec3::new(0.0, 1.0, 0.0),
                ],
                normals: vec![Vec3::Z; 4],
                uvs: vec![
                    Vec2::new(0.0, 1.0),
                    Vec2::new(mirror, 1.0),
                    Vec2::new(mirror, 0.0),
                    Vec2::new(0.0, 0.0),
                ],
                ..Default::default()
            };
            let corners = [[0, 1, 2], [0, 2, 3]];
            let t = mikktspace(&scene, &corners);
            for corner in t.iter().flatten() {
                assert!(
                    (corner.truncate() - expect).length() < 1e-5,
                    "mirror {mirror}: {corner}"
                );
                // The bitangent cross(n, t) w runs toward −v, up the image: +y here.
                let b = Vec3::Z.cross(corner.truncate()) * corner.w;
                assert!((b - Vec3::Y).length() < 1e-5, "mirror {mirror}: b {b}");
            }
        }
    }
}
