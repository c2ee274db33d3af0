//! Triangle meshes from Wavefront OBJ and PLY (ASCII or binary) files.

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
    /// A normal that is unit to rounding (|n|² within 4 ulps of 1) is kept as it is, so that
    /// the normals vitrum writes (`vitrum export`) read back to the same bits.
    #[inline]
    pub fn normal(&self, n: Vec3) -> Option<Vec3> {
        let unit = (n.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON;
        let n = if unit { n } else { crate::geometry::try_unit(n)? };
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

impl ObjMesh {
    /// Replaces the vertex normals by smooth ones recomputed from the triangles: at every vertex
    /// (corners at bit-identical placed positions, and with `split_at_uv_seams` also the same
    /// texture coordinates, are one vertex), the sum of its triangles' unit normals weighted by
    /// their angles at that corner (Thürmer and Wüthrich's weights, which do not depend on how a
    /// surface is split into triangles; Mitsuba 3's too), normalised.
    /// Used for files whose vertex normals are missing or placeholders.
    pub fn recompute_smooth_normals(&mut self, split_at_uv_seams: bool) {
        let key = |p: Vec3, uv: Option<Vec2>| {
            let uv = uv.filter(|_| split_at_uv_seams).unwrap_or(Vec2::ZERO);
            [p.x.to_bits(), p.y.to_bits(), p.z.to_bits(), uv.x.to_bits(), uv.y.to_bits()]
        };
        let corner_uv = |a: &VertexAttributes, k: usize| a.uv.map(|uv| uv[k]);
        let mut sums: std::collections::HashMap<[u32; 5], Vec3> =
            std::collections::HashMap::with_capacity(self.triangles.len());
        for (t, attributes) in self.triangles.iter().zip(&self.attributes) {
            let corners = t.vertices();
            let face = t.normal();
            for k in 0..3 {
                let p = corners[k];
                let angle = (corners[(k + 1) % 3] - p).angle_between(corners[(k + 2) % 3] - p);
                *sums.entry(key(p, corner_uv(attributes, k))).or_insert(Vec3::ZERO) += angle * face;
            }
        }
        for (t, attributes) in self.triangles.iter().zip(&mut self.attributes) {
            let face = t.normal();
            let corners = t.vertices();
            let normals = std::array::from_fn(|k| {
                let sum = sums[&key(corners[k], corner_uv(attributes, k))];
                crate::geometry::try_unit(sum).unwrap_or(face)
            });
            attributes.normals = Some(normals);
        }
        self.has_normals = true;
    }

    /// Turns every triangle over, as Mitsuba's `flip_normals` does: the winding reversed
    /// (`(a, b, c)` becomes `(a, c, b)`, its uv and vertex normals with it) and the vertex
    /// normals negated, so that the geometric and the shading normals both point the other way.
    /// The result is the mesh of a file written with the reversed winding and negated normals.
    pub fn flip_normals(&mut self) {
        for t in &mut self.triangles {
            let [a, b, c] = t.vertices();
            *t = Triangle::new(a, c, b);
        }
        for a in &mut self.attributes {
            if let Some([u0, u1, u2]) = a.uv {
                a.uv = Some([u0, u2, u1]);
            }
            if let Some([n0, n1, n2]) = a.normals {
                a.normals = Some([-n0, -n2, -n1]);
            }
        }
    }
}

/// The triangles of a mesh file by its extension: `.ply` ([`load_ply`]), else OBJ ([`load_obj`]).
pub fn load_mesh(path: &Path, placement: &MeshPlacement) -> Result<ObjMesh, String> {
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ply")) {
        load_ply(path, placement)
    } else {
        load_obj(path, placement)
    }
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
    let mut builder = MeshBuilder::default();
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
            let corners = |list: &Vec<u32>| [list[3 * k], list[3 * k + 1], list[3 * k + 2]];
            let uv = match uv_indices {
                Some(list) => {
                    let [i, j, l] = corners(list);
                    let (Some(u0), Some(u1), Some(u2)) = (texcoord(i), texcoord(j), texcoord(l)) else {
                        return Err(missing());
                    };
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
                    Some([n0, n1, n2])
                }
                None => None,
            };
            builder.push([a, b, c], uv, normals).map_err(|e| format!("{}: {e}", path.display()))?;
        }
    }
    builder.finish(path, has_uv, has_normals, hash)
}

/// The triangles of a mesh as they are read, checked and counted.
#[derive(Default)]
struct MeshBuilder {
    triangles: Vec<Triangle>,
    attributes: Vec<VertexAttributes>,
    degenerate: usize,
}

impl MeshBuilder {
    /// Adds the triangle of the placed corners `p` with their uv and (placed) normals, if any;
    /// a degenerate one is counted and skipped, a non-finite number refused.
    fn push(
        &mut self,
        p: [Vec3; 3],
        uv: Option<[Vec2; 3]>,
        normals: Option<[Vec3; 3]>,
    ) -> Result<(), String> {
        if !p.iter().all(|v| v.is_finite()) {
            return Err("a vertex is not a finite number".into());
        }
        if uv.is_some_and(|uv| !uv.iter().all(|t| t.is_finite())) {
            return Err("a texture coordinate is not a finite number".into());
        }
        if normals.is_some_and(|n| !n.iter().all(|n| n.is_finite())) {
            return Err("a normal is not a finite number".into());
        }
        let t = Triangle::new(p[0], p[1], p[2]);
        if t.is_degenerate() {
            self.degenerate += 1;
        } else {
            self.triangles.push(t);
            self.attributes.push(VertexAttributes { uv, normals });
        }
        Ok(())
    }

    /// The mesh of the file `path`, refused when no triangle is left.
    fn finish(self, path: &Path, has_uv: bool, has_normals: bool, hash: String) -> Result<ObjMesh, String> {
        if self.triangles.is_empty() {
            return Err(format!("{}: the mesh has no (non-degenerate) triangles", path.display()));
        }
        let MeshBuilder { triangles, attributes, degenerate } = self;
        Ok(ObjMesh { triangles, attributes, has_uv, has_normals, degenerate, hash })
    }
}

/// One element of a PLY file as vitrum reads it: a vertex (position, normal, uv) or a face
/// (its vertex indices); other properties are ignored.
#[derive(Default)]
struct PlyRecord {
    position: [f64; 3],
    normal: [f64; 3],
    uv: [f64; 2],
    /// Which of position, normal and uv the element gave (bits 0, 1, 2).
    given: u8,
    indices: Vec<i64>,
}

impl ply_rs_bw::ply::PropertyAccess for PlyRecord {
    fn new() -> Self {
        PlyRecord::default()
    }

    fn set_property(&mut self, name: &str, property: ply_rs_bw::ply::Property) {
        use ply_rs_bw::ply::Property as P;
        let scalar = match &property {
            P::Char(v) => Some(f64::from(*v)),
            P::UChar(v) => Some(f64::from(*v)),
            P::Short(v) => Some(f64::from(*v)),
            P::UShort(v) => Some(f64::from(*v)),
            P::Int(v) => Some(f64::from(*v)),
            P::UInt(v) => Some(f64::from(*v)),
            P::Float(v) => Some(f64::from(*v)),
            P::Double(v) => Some(*v),
            _ => None,
        };
        let list: Option<Vec<i64>> = match property {
            P::ListChar(v) => Some(v.into_iter().map(i64::from).collect()),
            P::ListUChar(v) => Some(v.into_iter().map(i64::from).collect()),
            P::ListShort(v) => Some(v.into_iter().map(i64::from).collect()),
            P::ListUShort(v) => Some(v.into_iter().map(i64::from).collect()),
            P::ListInt(v) => Some(v.into_iter().map(i64::from).collect()),
            P::ListUInt(v) => Some(v.into_iter().map(i64::from).collect()),
            _ => None,
        };
        let slot = match name {
            "x" => Some((0, 0)),
            "y" => Some((0, 1)),
            "z" => Some((0, 2)),
            "nx" => Some((1, 0)),
            "ny" => Some((1, 1)),
            "nz" => Some((1, 2)),
            "u" | "s" | "texture_u" | "texture_s" => Some((2, 0)),
            "v" | "t" | "texture_v" | "texture_t" => Some((2, 1)),
            _ => None,
        };
        match (slot, scalar) {
            (Some((0, i)), Some(v)) => (self.position[i], self.given) = (v, self.given | 1),
            (Some((1, i)), Some(v)) => (self.normal[i], self.given) = (v, self.given | 2),
            (Some((_, i)), Some(v)) => (self.uv[i], self.given) = (v, self.given | 4),
            _ => {}
        }
        if let (Some(list), "vertex_indices" | "vertex_index") = (list, name) {
            self.indices = list;
        }
    }
}

/// Most elements (vertices and faces together) a PLY file may declare.
pub const MAX_PLY_ELEMENTS: usize = 1 << 26;

/// The triangles of a PLY file (ASCII, binary little or big endian), placed by `placement`:
/// its `vertex` elements' `x y z`, `nx ny nz` (shading normals) and `u v` (or `s t`), its
/// `face` elements' `vertex_indices` (polygons as triangle fans). A header declaring more than
/// [`MAX_PLY_ELEMENTS`] elements, or more than the file's bytes could hold, is refused before
/// anything is allocated for them.
pub fn load_ply(path: &Path, placement: &MeshPlacement) -> Result<ObjMesh, String> {
    let cannot = |e: &dyn std::fmt::Display| format!("cannot load PLY file {}: {e}", path.display());
    let bytes = std::fs::read(path).map_err(|e| cannot(&e))?;
    let hash = super::compile::content_hash_bytes(&bytes);
    let parser = ply_rs_bw::parser::Parser::<PlyRecord>::new();
    let mut reader = std::io::BufReader::new(std::io::Cursor::new(&bytes));
    let header = parser.read_header(&mut reader).map_err(|e| cannot(&e))?;
    let declared: usize = header.elements.values().map(|e| e.count).fold(0, usize::saturating_add);
    if declared > MAX_PLY_ELEMENTS || declared > bytes.len() {
        return Err(cannot(&format!(
            "the header declares {declared} elements, more than the file's {} bytes can hold or vitrum's \
             limit of {MAX_PLY_ELEMENTS}",
            bytes.len()
        )));
    }
    let payload = parser.read_payload(&mut reader, &header).map_err(|e| cannot(&e))?;
    let empty = Vec::new();
    let vertices = payload.get("vertex").unwrap_or(&empty);
    let faces = payload.get("face").unwrap_or(&empty);
    let every = |bit: u8| !vertices.is_empty() && vertices.iter().all(|v| v.given & bit != 0);
    if !every(1) {
        return Err(cannot(&"every vertex needs x, y and z"));
    }
    let (has_normals, has_uv) = (every(2), every(4));
    let vertex = |i: i64| -> Result<&PlyRecord, String> {
        usize::try_from(i)
            .ok()
            .and_then(|i| vertices.get(i))
            .ok_or_else(|| format!("{}: a face refers to vertex {i}, which does not exist", path.display()))
    };
    let mut builder = MeshBuilder::default();
    for face in faces {
        for k in 1..face.indices.len().saturating_sub(1) {
            let corners = [vertex(face.indices[0])?, vertex(face.indices[k])?, vertex(face.indices[k + 1])?];
            let point = |r: &PlyRecord| placement.point(glam::DVec3::from_array(r.position).as_vec3());
            let normal = |r: &PlyRecord| {
                placement.normal(glam::DVec3::from_array(r.normal).as_vec3()).unwrap_or(Vec3::ZERO)
            };
            let uv = |r: &PlyRecord| glam::DVec2::from_array(r.uv).as_vec2();
            builder
                .push(
                    corners.map(point),
                    has_uv.then(|| corners.map(uv)),
                    has_normals.then(|| corners.map(normal)),
                )
                .map_err(|e| format!("{}: {e}", path.display()))?;
        }
    }
    builder.finish(path, has_uv, has_normals, hash)
}
