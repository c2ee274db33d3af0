//! Triangle meshes from Wavefront OBJ files.

use super::transform::Transform;
use crate::geometry::Triangle;
use glam::Vec3;
use std::path::Path;

/// Where a mesh's vertices go: `scale·p + translate` (the mesh's own fields), then the object's
/// `transform` when it has one.
#[derive(Clone, Copy, Debug)]
pub struct MeshPlacement {
    /// Uniform scale of the file's coordinates (> 0).
    pub scale: f32,
    /// Translation after `scale`.
    pub translate: Vec3,
    /// The object's transform, applied after `scale` and `translate`.
    pub transform: Option<Transform>,
}

impl MeshPlacement {
    /// The placement that leaves the file's coordinates as they are.
    pub const IDENTITY: MeshPlacement = MeshPlacement { scale: 1.0, translate: Vec3::ZERO, transform: None };

    /// A vertex of the file placed in the scene.
    #[inline]
    pub fn point(&self, p: Vec3) -> Vec3 {
        let q = p * self.scale + self.translate;
        match &self.transform {
            Some(t) => t.point(q),
            None => q,
        }
    }
}

/// An OBJ file's triangles.
pub struct ObjMesh {
    /// The triangles, placed ([`MeshPlacement`]).
    pub triangles: Vec<Triangle>,
    /// Degenerate triangles skipped.
    pub degenerate: usize,
    /// The content hash of the file's bytes (part of the scene's hash).
    pub hash: String,
}

/// The triangles of an OBJ file, placed by `placement` (materials are not read).
pub fn load_obj(path: &Path, placement: &MeshPlacement) -> Result<ObjMesh, String> {
    let cannot = |e: &dyn std::fmt::Display| format!("cannot load OBJ file {}: {e}", path.display());
    let bytes = std::fs::read(path).map_err(|e| cannot(&e))?;
    let hash = super::compile::content_hash_bytes(&bytes);
    // Positions only: separate index lists (no merging of position/normal/uv tuples) are faster.
    let options = tobj::LoadOptions { triangulate: true, single_index: false, ..Default::default() };
    let no_materials = |_: &Path| Err(tobj::LoadError::OpenFileFailed);
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(&bytes), &options, no_materials)
        .map_err(|e| cannot(&e))?;
    let mut triangles = Vec::new();
    let mut degenerate = 0;
    for model in &models {
        let m = &model.mesh;
        let vertex = |i: u32| -> Option<Vec3> {
            let i = i as usize * 3;
            let p = m.positions.get(i..i + 3)?;
            Some(placement.point(Vec3::new(p[0], p[1], p[2])))
        };
        for tri in m.indices.chunks_exact(3) {
            let (Some(a), Some(b), Some(c)) = (vertex(tri[0]), vertex(tri[1]), vertex(tri[2])) else {
                return Err(format!("{}: a face refers to a vertex that does not exist", path.display()));
            };
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                return Err(format!("{}: a vertex is not a finite number", path.display()));
            }
            let t = Triangle::new(a, b, c);
            if t.is_degenerate() {
                degenerate += 1;
            } else {
                triangles.push(t);
            }
        }
    }
    if triangles.is_empty() {
        return Err(format!("{}: the mesh has no (non-degenerate) triangles", path.display()));
    }
    Ok(ObjMesh { triangles, degenerate, hash })
}
