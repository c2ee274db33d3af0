//! Triangle meshes from Wavefront OBJ files.

use crate::geometry::Triangle;
use glam::Vec3;
use std::path::Path;

/// An OBJ file's triangles.
pub struct ObjMesh {
    /// The triangles after `scale` then `translate`.
    pub triangles: Vec<Triangle>,
    /// Degenerate triangles skipped.
    pub degenerate: usize,
    /// The content hash of the file's bytes (part of the scene's hash).
    pub hash: String,
}

/// The triangles of an OBJ file after `scale` then `translate` (materials are not read).
pub fn load_obj(path: &Path, scale: f32, translate: Vec3) -> Result<ObjMesh, String> {
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
            Some(Vec3::new(p[0], p[1], p[2]) * scale + translate)
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
