//! Where a flattened scene's triangles come from in its glTF document: for each triangle, the
//! node whose mesh it belongs to, that mesh, and the document's material, so that ID passes
//! ([`crate::render::passes`]) can name them by the file's own indices.
//!
//! The loader visits each node's mesh once and appends its primitives' triangles in order, so
//! the triangles of one node's mesh are contiguous: a table of runs (first triangle, node,
//! mesh), 12 bytes per mesh instance, answers for every triangle by binary search, instead
//! of two indices per triangle. Materials map from the scene's index (whose 0 is glTF's
//! default material, which the document does not hold) to the document's.
//!
//! A scene built in code rather than loaded from a file has no runs and no materials here:
//! its triangles have no node, mesh or material in any document, and their IDs are −1.

/// A triangle's node, mesh and material as the glTF document numbers them; None where the
/// document has none (a primitive without a material, or a scene not loaded from glTF).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TriangleOrigin {
    /// The index into the document's `nodes` of the node whose mesh holds the triangle.
    pub node: Option<u32>,
    /// The index into the document's `meshes`.
    pub mesh: Option<u32>,
    /// The index into the document's `materials`.
    pub material: Option<u32>,
}

/// Triangles from `first_triangle` up to the next run's first triangle (or the last
/// triangle) belong to node `node`'s mesh `mesh`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OriginRun {
    pub first_triangle: u32,
    pub node: u32,
    pub mesh: u32,
}

/// The document's indices of a scene's triangles and materials ([`crate::scene::Scene::origins`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Origins {
    /// Runs of triangles, by ascending first triangle.
    pub runs: Vec<OriginRun>,
    /// The document's index of each of the scene's materials; None for one the document
    /// does not hold (glTF's default material, the scene's material 0).
    pub materials: Vec<Option<u32>>,
}

impl Origins {
    /// Records that the triangles from `first_triangle` on are node `node`'s mesh `mesh`
    /// (called before each primitive the loader appends). A primitive of the same node and
    /// mesh as the last run extends it; a run that got no triangle is replaced.
    pub fn start(&mut self, first_triangle: u32, node: u32, mesh: u32) {
        let run = OriginRun {
            first_triangle,
            node,
            mesh,
        };
        match self.runs.last_mut() {
            Some(last) if (last.node, last.mesh) == (node, mesh) => {}
            Some(last) if last.first_triangle == first_triangle => *last = run,
            _ => self.runs.push(run),
        }
    }

    /// Triangle `triangle`'s origin, `material` its material in the scene.
    pub fn of(&self, triangle: u32, material: u32) -> TriangleOrigin {
        let after = self.runs.partition_point(|r| r.first_triangle <= triangle);
        let run = after.checked_sub(1).map(|i| self.runs[i]);
        TriangleOrigin {
            node: run.map(|r| r.node),
            mesh: run.map(|r| r.mesh),
            material: self.materials.get(material as usize).copied().flatten(),
        }
    }

    /// The largest node, mesh and material index any triangle's origin may name (None where
    /// none names one).
    pub fn largest(&self) -> TriangleOrigin {
        TriangleOrigin {
            node: self.runs.iter().map(|r| r.node).max(),
            mesh: self.runs.iter().map(|r| r.mesh).max(),
            material: self.materials.iter().flatten().copied().max(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_name_every_triangle_until_the_next_run() {
        let mut o = Origins {
            materials: vec![None, Some(0), Some(1)],
            ..Default::default()
        };
        // Node 3's mesh 0 (two primitives: one run), a node whose primitive added nothing,
        // node 5's mesh 0 again, then node 1's mesh 2.
        o.start(0, 3, 0);
        o.start(2, 3, 0);
        o.start(4, 7, 1);
        o.start(4, 5, 0);
        o.start(6, 1, 2);
        assert_eq!(o.runs.len(), 3, "{:?}", o.runs);
        let want = [
            (3, 0),
            (3, 0),
            (3, 0),
            (3, 0),
            (5, 0),
            (5, 0),
            (1, 2),
            (1, 2),
        ];
        for (t, &(node, mesh)) in want.iter().enumerate() {
            let got = o.of(t as u32, 1);
            assert_eq!(
                (got.node, got.mesh),
                (Some(node), Some(mesh)),
                "triangle {t}"
            );
        }
        assert_eq!(o.of(100, 1).node, Some(1), "the last run lasts to the end");
        // Materials: the default one has no index in the document; the file's k is the
        // scene's k + 1; one the table does not know has none.
        assert_eq!(o.of(0, 0).material, None);
        assert_eq!(o.of(0, 1).material, Some(0));
        assert_eq!(o.of(0, 2).material, Some(1));
        assert_eq!(o.of(0, 9).material, None);
        let largest = TriangleOrigin {
            node: Some(5),
            mesh: Some(2),
            material: Some(1),
        };
        assert_eq!(o.largest(), largest);
        // A scene built in code: nothing named.
        assert_eq!(Origins::default().of(0, 0), TriangleOrigin::default());
        assert_eq!(Origins::default().largest(), TriangleOrigin::default());
    }
}
