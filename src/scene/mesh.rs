//! Triangle meshes from Wavefront OBJ files.

use super::transform::Transform;
use crate::geometry::{Triangle, VertexAttributes};
use glam::{Vec2, Vec3};
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

    /// A vertex normal of the file placed in the scene (unit; `None` for a zero normal): the
    /// uniform `scale` leaves it as it is, the transform carries it by its inverse transpose.
    #[inline]
    pub fn normal(&self, n: Vec3) -> Option<Vec3> {
        let n = crate::geometry::try_unit(n)?;
        match &self.transform {
            Some(t) => t.normal(n),
            None => Some(n),
        }
    }
}

/// An OBJ file's triangles, with their texture coordinates and vertex normals.
pub struct ObjMesh {
    /// The triangles, placed ([`MeshPlacement`]).
    pub triangles: Vec<Triangle>,
    /// Per triangle (in the same order), its vertices' uv and shading normals (placed).
    pub attributes: Vec<VertexAttributes>,
    /// Whether the file gives texture coordinates (`vt`): then a hit's uv is the interpolated
    /// vt, else the triangle's barycentrics (b1, b2).
    pub has_uv: bool,
    /// Whether the file gives vertex normals (`vn`), which become shading normals.
    pub has_normals: bool,
    /// Degenerate triangles skipped.
    pub degenerate: usize,
    /// The content hash of the file's bytes (part of the scene's hash).
    pub hash: String,
}

/// The triangles of an OBJ file, placed by `placement`, with their `vt` and `vn` when the file
/// has them (materials are not read).
pub fn load_obj(path: &Path, placement: &MeshPlacement) -> Result<ObjMesh, String> {
    let cannot = |e: &dyn std::fmt::Display| format!("cannot load OBJ file {}: {e}", path.display());
    let bytes = std::fs::read(path).map_err(|e| cannot(&e))?;
    let hash = super::compile::content_hash_bytes(&bytes);
    // Separate index lists for positions, texture coordinates and normals (no merging of
    // position/normal/uv tuples, which is slower).
    let options = tobj::LoadOptions { triangulate: true, single_index: false, ..Default::default() };
    let no_materials = |_: &Path| Err(tobj::LoadError::OpenFileFailed);
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(&bytes), &options, no_materials)
        .map_err(|e| cannot(&e))?;
    let mut triangles = Vec::new();
    let mut attributes = Vec::new();
    let mut degenerate = 0;
    let missing = || {
        format!(
            "{}: a face refers to a vertex, texture coordinate or normal that does not exist",
            path.display()
        )
    };
    let with_uv = models.iter().filter(|m| !m.mesh.texcoord_indices.is_empty()).count();
    let has_uv = with_uv > 0;
    if has_uv && with_uv < models.len() {
        return Err(format!(
            "{}: some objects or groups have texture coordinates (vt) and others do not: give every face vt, or none",
            path.display()
        ));
    }
    let mut has_normals = false;
    for model in &models {
        let m = &model.mesh;
        let vertex = |i: u32| -> Option<Vec3> {
            let i = i as usize * 3;
            let p = m.positions.get(i..i + 3)?;
            Some(placement.point(Vec3::new(p[0], p[1], p[2])))
        };
        let texcoord = |i: u32| -> Option<Vec2> {
            let i = i as usize * 2;
            let t = m.texcoords.get(i..i + 2)?;
            Some(Vec2::new(t[0], t[1]))
        };
        let normal = |i: u32| -> Option<Vec3> {
            let i = i as usize * 3;
            let n = m.normals.get(i..i + 3)?;
            // A zero normal stays zero (the interpolation then falls back to the face).
            Some(placement.normal(Vec3::new(n[0], n[1], n[2])).unwrap_or(Vec3::ZERO))
        };
        let uv_indices = (!m.texcoord_indices.is_empty()).then_some(&m.texcoord_indices);
        let normal_indices = (!m.normal_indices.is_empty()).then_some(&m.normal_indices);
        for list in [uv_indices, normal_indices].into_iter().flatten() {
            if list.len() != m.indices.len() {
                return Err(missing());
            }
        }
        has_normals |= normal_indices.is_some();
        for (k, tri) in m.indices.chunks_exact(3).enumerate() {
            let (Some(a), Some(b), Some(c)) = (vertex(tri[0]), vertex(tri[1]), vertex(tri[2])) else {
                return Err(missing());
            };
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                return Err(format!("{}: a vertex is not a finite number", path.display()));
            }
            let corners = |list: &Vec<u32>| [list[3 * k], list[3 * k + 1], list[3 * k + 2]];
            let uv = match uv_indices {
                Some(list) => {
                    let [i, j, l] = corners(list);
                    let (Some(u0), Some(u1), Some(u2)) = (texcoord(i), texcoord(j), texcoord(l)) else {
                        return Err(missing());
                    };
                    if !(u0.is_finite() && u1.is_finite() && u2.is_finite()) {
                        return Err(format!(
                            "{}: a texture coordinate is not a finite number",
                            path.display()
                        ));
                    }
                    Some([u0, u1, u2])
                }
                None => None,
            };
            let normals = match normal_indices {
                Some(list) => {
                    let [i, j, l] = corners(list);
                    let (Some(n0), Some(n1), Some(n2)) = (normal(i), normal(j), normal(l)) else {
                        return Err(missing());
                    };
                    if !(n0.is_finite() && n1.is_finite() && n2.is_finite()) {
                        return Err(format!("{}: a normal is not a finite number", path.display()));
                    }
                    Some([n0, n1, n2])
                }
                None => None,
            };
            let t = Triangle::new(a, b, c);
            if t.is_degenerate() {
                degenerate += 1;
            } else {
                triangles.push(t);
                attributes.push(VertexAttributes { uv, normals });
            }
        }
    }
    if triangles.is_empty() {
        return Err(format!("{}: the mesh has no (non-degenerate) triangles", path.display()));
    }
    Ok(ObjMesh { triangles, attributes, has_uv, has_normals, degenerate, hash })
}
