//! `EXT_mesh_gpu_instancing` and the choice to instance a mesh: a node's instances' attributes,
//! their count and transforms, and whether a mesh placed so often is kept once.

use glam::DMat4;
use gltf::accessor::{DataType, Dimensions};

use super::accessors::{check_accessor, expect_format, read_floats, QUANTIZED_UNIT};
/// A loader's error message.
type Result<T> = std::result::Result<T, String>;

/// True when `mesh`, placed `placements` times, is stored once and instanced: placed more than
/// once, unless `flatten_instances`. Alpha coverage is tested inside instances (BLEND's coin
/// reads the world ray's key and the instance: `accel::coverage`), and an emitting mesh's
/// triangles are lights once per instance.
pub(super) fn instanced_mesh(placements: u64, flatten_instances: bool) -> bool {
    placements >= 2 && !flatten_instances
}

/// A node's `EXT_mesh_gpu_instancing` attributes (TRANSLATION, ROTATION, SCALE) as accessor
/// indices, or None without the extension.
pub(super) fn instancing_attributes(node: &gltf::Node) -> Option<Vec<(String, usize)>> {
    let ext = node.extension_value("EXT_mesh_gpu_instancing")?;
    let attributes = ext.get("attributes").and_then(|a| a.as_object());
    Some(
        attributes
            .into_iter()
            .flatten()
            .filter_map(|(k, v)| Some((k.clone(), v.as_u64()? as usize)))
            .collect(),
    )
}

/// The number of instances a node's `EXT_mesh_gpu_instancing` draws (its attributes'
/// largest accessor count: they must all agree, which reading them checks), or None without
/// the extension.
pub(super) fn instance_count(doc: &gltf::Document, node: &gltf::Node) -> Option<usize> {
    let attributes = instancing_attributes(node)?;
    Some(
        attributes
            .iter()
            .filter_map(|&(_, i)| doc.accessors().nth(i).map(|a| a.count()))
            .max()
            .unwrap_or(0),
    )
}

/// The transforms of a node's `EXT_mesh_gpu_instancing` instances, each translation ×
/// rotation × scale of its attributes (any may be absent: identity), or None without the
/// extension. Errors name the node and what is wrong.
pub(super) fn instance_transforms(
    doc: &gltf::Document,
    node: &gltf::Node,
    buffers: &[Vec<u8>],
) -> Result<Option<Vec<DMat4>>> {
    let Some(attributes) = instancing_attributes(node) else {
        return Ok(None);
    };
    let label = format!("node {} EXT_mesh_gpu_instancing", node.index());
    let count = instance_count(doc, node).unwrap_or(0);
    let mut t = vec![glam::DVec3::ZERO; count];
    let mut r = vec![glam::DQuat::IDENTITY; count];
    let mut sc = vec![glam::DVec3::ONE; count];
    for (name, index) in attributes {
        let acc = doc.accessors().nth(index).ok_or_else(|| {
            format!("{label}: {name} names accessor {index}, which does not exist")
        })?;
        check_accessor(buffers, &acc).map_err(|e| format!("{label} {name}: {e}"))?;
        if acc.count() != count {
            return Err(format!(
                "{label}: {name} has {} instances, another attribute {count}",
                acc.count()
            ));
        }
        let unreadable = || format!("{label}: {name} cannot be read from its buffer");
        match name.as_str() {
            "TRANSLATION" | "SCALE" => {
                expect_format(&acc, Dimensions::Vec3, &[DataType::F32], &label, &name)?;
                let v: Vec<[f32; 3]> = read_floats(&acc, buffers).ok_or_else(unreadable)?;
                let target = if name == "SCALE" { &mut sc } else { &mut t };
                for (dst, src) in target.iter_mut().zip(v) {
                    *dst = glam::Vec3::from_array(src).as_dvec3();
                }
            }
            "ROTATION" => {
                expect_format(&acc, Dimensions::Vec4, QUANTIZED_UNIT, &label, &name)?;
                let v: Vec<[f32; 4]> = read_floats(&acc, buffers).ok_or_else(unreadable)?;
                for (k, (dst, src)) in r.iter_mut().zip(v).enumerate() {
                    let q = glam::Quat::from_array(src).as_dquat();
                    if !q.is_finite() || q.length() == 0.0 {
                        return Err(format!(
                            "{label}: instance {k}'s rotation is not a rotation"
                        ));
                    }
                    *dst = q.normalize();
                }
            }
            // Custom attributes (_ID and the like) place nothing.
            _ => {}
        }
    }
    Ok(Some(
        (0..count)
            .map(|k| DMat4::from_scale_rotation_translation(sc[k], r[k], t[k]))
            .collect(),
    ))
}
