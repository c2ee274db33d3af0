//! The compiled, immutable scene every integrator renders: primitives in one obvhs CwBvh,
//! materials, lights, camera and the effects the scene calls for.

pub mod bodies;
pub mod compile;
pub mod desc;
pub mod describe;
pub mod effects;
pub mod mesh;
pub mod mitsuba;
pub mod overlap;
pub mod source;
pub mod transform;
mod traversal;

pub use compile::{load, load_default, load_str};
pub use effects::{Effect, EffectUse, Effects};
pub use source::SceneError;

use crate::camera::Camera;
use crate::geometry::{Ray, Shape, SurfaceHit, VertexAttributes};
use crate::light::{Light, SceneSphere};
use crate::material::Material;
use crate::methods::Method;
use crate::params::{ManifoldParams, MergeParams, MetropolisParams, RenderParams, SsaaParams};
use crate::sampler::SamplerKind;
use glam::{Vec3, Vec3A};
use obvhs::cwbvh::CwBvh;
use std::cell::OnceCell;
use std::collections::BTreeMap;

/// The text of the embedded default scene (the thesis's Cornell box with glass bodies).
pub const DEFAULT_SCENE: &str = include_str!("../../scenes/cornell-glass.toml");

/// The attribute index of a primitive without vertex attributes.
pub(crate) const NO_ATTRIBUTES: u32 = u32::MAX;

/// One BVH primitive: a shape with its material, the light it emits for (if any), and the
/// object of the scene file it came from.
#[derive(Clone, Debug)]
pub struct Primitive {
    /// The geometry.
    pub shape: Shape,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Index into [`Scene::lights`] when the primitive is an emitter.
    pub light: Option<u32>,
    /// Index into [`Scene::objects`].
    pub object: u32,
    /// Linear velocity (scene units per unit of time) when the object moves; the shape is
    /// where it is at time 0.
    pub velocity: Option<Vec3>,
}

impl Primitive {
    /// Conservative bounds over the shutter interval `(open, close)`.
    pub fn bounds_over(&self, shutter: (f32, f32)) -> crate::geometry::Bounds {
        let b = self.shape.bounds();
        match self.velocity {
            None => b,
            Some(v) => {
                let (a, c) = (v * shutter.0, v * shutter.1);
                crate::geometry::Bounds { min: (b.min + a).min(b.min + c), max: (b.max + a).max(b.max + c) }
            }
        }
    }
}

/// A ray's closest hit.
#[derive(Clone, Copy, Debug)]
pub struct Intersection {
    /// Surface geometry at the hit.
    pub hit: SurfaceHit,
    /// Index into [`Scene::primitives`].
    pub primitive: u32,
}

/// Render settings stored with the scene (command-line options override them).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Integrator name.
    pub integrator: String,
    /// Samples per pixel.
    pub spp: u32,
    /// The maximum depths the scene sets per method (`[render.METHOD] max_depth`), by name.
    pub max_depths: BTreeMap<String, u32>,
    /// The engine settings the scene sets per bidirectional method, by name: the cap on light
    /// sub-paths for all four (`[render.bpt] max_light_paths = …`), the merge radius and α for
    /// the merging ones (`[render.vcm] radius = …`).
    pub merging: BTreeMap<String, MergeParams>,
    /// Seed of the random streams.
    pub seed: u64,
    /// Ambient radiance of the empirical Phong model.
    pub ambient: Vec3,
    /// Radiance of rays that leave the scene.
    pub background: Vec3,
    /// Constant dielectric reflectance instead of exact Fresnel.
    pub reflectance: Option<f32>,
    /// PNG preview exposure in stops.
    pub exposure: f32,
    /// Whether to render spectrally.
    pub spectral: SpectralMode,
    /// Sample distribution.
    pub sampler: SamplerKind,
    /// Settings of the supersampling integrator.
    pub ssaa: SsaaParams,
    /// Settings of the Metropolis methods by name (`[render.pssmlt]`, `[render.mmlt]`; the
    /// defaults where a table is absent).
    pub metropolis: BTreeMap<String, MetropolisParams>,
    /// Settings of manifold next-event estimation (`[render.mnee]`).
    pub manifold: ManifoldParams,
}

impl RenderSettings {
    /// The maximum depth of a render by `method`: `cli` (the command line's `--max-depth`), else
    /// the scene's `[render.METHOD] max_depth`, else the method's own default.
    pub fn max_depth_of(&self, method: Method, cli: Option<u32>) -> u32 {
        cli.or_else(|| self.max_depths.get(method.name()).copied()).unwrap_or(method.info().default_max_depth)
    }

    /// The parameters of a render by `method` with the scene's settings, the depth as
    /// [`RenderSettings::max_depth_of`] gives it.
    pub fn params_of(&self, method: Method, cli_depth: Option<u32>) -> RenderParams {
        RenderParams {
            max_depth: self.max_depth_of(method, cli_depth),
            reflectance: self.reflectance,
            ssaa: self.ssaa,
            merging: self.merging.get(method.name()).copied().unwrap_or_default(),
            metropolis: self.metropolis.get(method.name()).copied().unwrap_or_default(),
            manifold: (method == Method::Mnee).then_some(self.manifold),
            engine: crate::params::EngineOption::Auto,
        }
    }
}

/// When to trace wavelengths instead of RGB.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectralMode {
    /// Spectral exactly when the scene calls for dispersion.
    Auto,
    /// Always (a non-dispersive scene then renders the same image within noise).
    On,
    /// Never (dispersive media use their nominal index n_d).
    Off,
}

impl SpectralMode {
    /// The name the scene file and the command line use: `auto`, `on` or `off`.
    pub fn name(self) -> &'static str {
        match self {
            SpectralMode::Auto => "auto",
            SpectralMode::On => "on",
            SpectralMode::Off => "off",
        }
    }

    /// Parse `auto`, `on` or `off`.
    pub fn from_name(name: &str) -> Option<SpectralMode> {
        match name {
            "auto" => Some(SpectralMode::Auto),
            "on" => Some(SpectralMode::On),
            "off" => Some(SpectralMode::Off),
            _ => None,
        }
    }

    /// Whether a scene with these effects is rendered spectrally.
    pub fn resolve(self, effects: &Effects) -> bool {
        match self {
            SpectralMode::Auto => effects.has(Effect::Dispersion),
            SpectralMode::On => true,
            SpectralMode::Off => false,
        }
    }
}

/// `ray` in the frame of an object moving with velocity `v` (the object at rest at time 0).
#[inline]
fn moved(ray: &Ray, v: Vec3) -> Ray {
    Ray { origin: ray.origin - v * ray.time, ..*ray }
}

/// What `vitrum info` shows about one object of the scene file.
#[derive(Clone, Debug)]
pub struct ObjectSummary {
    /// The object's name (given, or made from its kind and index).
    pub name: String,
    /// Shape or body kind as written in the file.
    pub kind: String,
    /// Material name.
    pub material: String,
    /// How many BVH primitives it expanded into.
    pub primitives: usize,
    /// For a mesh, whether its triangles carry texture coordinates (`vt`) and vertex normals
    /// (`vn`, shading normals): `(uv, normals)`; `(false, false)` for every other object.
    pub mesh_attributes: (bool, bool),
}

/// Where the scene came from: its display name and a hash of its text and meshes.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneOrigin {
    /// File path, or `<embedded default scene>`.
    pub name: String,
    /// 64-bit FNV-1a hash of the scene text (and of the mesh files it reads), in hex.
    pub hash: String,
}

/// Statistics of the acceleration structure.
#[derive(Clone, Debug)]
pub struct BvhStats {
    /// Number of CwBvh nodes.
    pub nodes: usize,
    /// Number of primitives.
    pub primitives: usize,
    /// Depth of the node tree (root = 1).
    pub depth: usize,
    /// Build time in seconds.
    pub build_seconds: f64,
    /// Scene bounds (min, max).
    pub bounds: (Vec3, Vec3),
    /// Power-of-two factor from world to BVH coordinates.
    pub scale: f32,
}

/// The compiled scene: immutable and shared by all render threads.
pub struct Scene {
    /// Primitives in BVH order.
    pub primitives: Vec<Primitive>,
    /// Materials referenced by primitives.
    pub materials: Vec<Material>,
    /// Light sources.
    pub lights: Vec<Light>,
    /// The camera.
    pub camera: Camera,
    /// Render defaults from the file.
    pub settings: RenderSettings,
    /// Effects the scene calls for, with reasons.
    pub effects: Effects,
    /// The objects of the scene file.
    pub objects: Vec<ObjectSummary>,
    /// Where the scene came from.
    pub origin: SceneOrigin,
    /// BVH statistics.
    pub bvh_stats: BvhStats,
    /// Warnings found while compiling (degenerate triangles skipped, …).
    pub warnings: Vec<String>,
    /// The smooth dielectric objects manifold next-event estimation seeds towards.
    casters: Vec<crate::manifold::Caster>,
    bvh: CwBvh,
    /// The vertex attributes (uv, shading normals) of mesh triangles that have them.
    attributes: Vec<VertexAttributes>,
    /// Per primitive (in BVH order), its index into `attributes` or [`NO_ATTRIBUTES`]; empty
    /// when no primitive has attributes.
    attribute_index: Vec<u32>,
    /// Whether any primitive moves (only then does traversal look at velocities).
    has_motion: bool,
    /// Whether any texture reads a hit's uv (an image texture on a material or an emitter):
    /// without one, hits skip the angular coordinates of spheres, cylinders and disks.
    reads_surface_uv: bool,

    /// World = BVH coordinates × `bvh_scale` (a power of two, so the mapping is exact). The
    /// CwBvh culls boxes closer than a fixed 1e-4 along the ray; normalising the scene to a size
    /// of about 1000 makes that distance negligible at any scene scale.
    bvh_scale: f32,
}

impl Scene {
    /// The closest hit along `ray` with distance in (0, `tmax`), with moving primitives where
    /// they are at `ray.time`. Of primitives hit at exactly the same distance (coincident
    /// surfaces written identically) the one compiled first wins: the first listed object,
    /// whatever the BVH's traversal order.
    pub fn intersect(&self, ray: &Ray, tmax: f32) -> Option<Intersection> {
        // A static scene pays nothing for motion blur: its traversal never looks at velocities.
        let (t, primitive, bary) = if self.has_motion {
            self.closest(ray, tmax, |prim, limit| {
                match prim.velocity {
                    None => prim.shape.intersect(ray, 0.0, limit),
                    Some(v) => prim.shape.intersect(&moved(ray, v), 0.0, limit),
                }
                .map(|t| (t, None))
            })
        } else {
            let sheared = OnceCell::new();
            self.closest(ray, tmax, |prim, limit| prim.shape.hit_sheared(ray, &sheared, 0.0, limit))
        }?;
        Some(self.record(ray, t, primitive as u32, bary))
    }

    /// The intersection record of `ray` with `primitive` at distance `t` (a distance its shape's
    /// test returned, with a triangle's barycentrics where the test gave them): the surface
    /// geometry, moved to `ray.time` for a moving primitive, with the mesh's vertex attributes.
    #[inline]
    pub fn record(&self, ray: &Ray, t: f32, primitive: u32, bary: Option<[f32; 3]>) -> Intersection {
        let prim = &self.primitives[primitive as usize];
        let mut hit = match prim.velocity {
            None => prim.shape.surface_with(ray, t, bary, self.reads_surface_uv),
            Some(v) => {
                let mut h = prim.shape.surface_with(&moved(ray, v), t, None, self.reads_surface_uv);
                let shift = v * ray.time;
                h.p += shift;
                h.p_error += crate::geometry::gamma(2) * h.p.abs().max_element();
                h
            }
        };
        if let Some(a) = self.vertex_attributes(primitive) {
            a.apply(&mut hit);
        }
        Intersection { hit, primitive }
    }

    /// Where `primitive` (an index into [`Scene::primitives`], which are in BVH order) was
    /// compiled among the scene's primitives: of two hits at exactly the same distance, the
    /// one compiled first wins; an exporter that writes them in this order gives a file that
    /// compiles to the same BVH.
    #[inline]
    pub fn compile_rank(&self, primitive: u32) -> u32 {
        self.bvh.primitive_indices[primitive as usize]
    }

    /// The acceleration structure (obvhs's CwBvh, in BVH coordinates: world ÷
    /// [`Scene::bvh_scale`]), for traversals other than [`Scene::intersect`]'s (the lanes').
    pub fn bvh(&self) -> &CwBvh {
        &self.bvh
    }

    /// World = BVH coordinates × this power of two (see [`Scene::bvh`]).
    pub fn bvh_scale(&self) -> f32 {
        self.bvh_scale
    }

    /// Whether any primitive moves.
    pub fn has_motion(&self) -> bool {
        self.has_motion
    }

    /// Whether `ray` meets, within (0, `tmax`), a primitive that `blocks(primitive, t)` counts as
    /// a blocker; the search stops at the first one (an occlusion query for shadow rays).
    pub fn occluded(&self, ray: &Ray, tmax: f32, blocks: impl Fn(u32, f32) -> bool) -> bool {
        let blocked = |t: Option<f32>, id: usize| t.filter(|&t| blocks(id as u32, t));
        if self.has_motion {
            self.any_hit(ray, tmax, |prim, id| {
                let t = match prim.velocity {
                    None => prim.shape.intersect(ray, 0.0, tmax),
                    Some(v) => prim.shape.intersect(&moved(ray, v), 0.0, tmax),
                };
                blocked(t, id)
            })
        } else {
            let sheared = OnceCell::new();
            self.any_hit(ray, tmax, |prim, id| {
                blocked(prim.shape.intersect_sheared(ray, &sheared, 0.0, tmax), id)
            })
        }
    }

    /// Whether a BVH traversal along `ray` within (0, `tmax`) finds a primitive for which
    /// `hit(prim, id)` gives a distance; it stops at the first.
    #[inline]
    fn any_hit(&self, ray: &Ray, tmax: f32, hit: impl Fn(&Primitive, usize) -> Option<f32>) -> bool {
        let inv = 1.0 / self.bvh_scale;
        let bray = self.bvh_ray(ray, tmax);
        traversal::any(&self.bvh, bray, |_, id| {
            hit(&self.primitives[id], id).map_or(f32::INFINITY, |t| t * inv)
        })
    }

    /// `ray` in BVH coordinates up to `tmax`, with its direction canonicalised (the CwBvh misses
    /// rays with a −0.0 component).
    #[inline]
    fn bvh_ray(&self, ray: &Ray, tmax: f32) -> obvhs::ray::Ray {
        let inv = 1.0 / self.bvh_scale;
        obvhs::ray::Ray::new(
            Vec3A::from(ray.origin * inv),
            Vec3A::from(ray.dir) + Vec3A::ZERO,
            0.0,
            tmax * inv,
        )
    }

    /// The closest (distance, primitive, extra) of a BVH traversal along `ray` within
    /// (0, `tmax`), where `hit(prim, limit)` is the primitive's hit distance below `limit` with
    /// whatever `extra` the hit record will need. Ties go to the primitive compiled first (the
    /// BVH tests them in its own order and keeps the first).
    #[inline]
    fn closest<E: Copy>(
        &self,
        ray: &Ray,
        tmax: f32,
        hit: impl Fn(&Primitive, f32) -> Option<(f32, E)>,
    ) -> Option<(f32, usize, E)> {
        let inv = 1.0 / self.bvh_scale;
        let bray = self.bvh_ray(ray, tmax);
        let source = &self.bvh.primitive_indices;
        let mut best: Option<(f32, usize, E)> = None;
        traversal::closest(&self.bvh, bray, |_, id| {
            // Up to and including the best distance so far, to see ties.
            let limit = best.map_or(tmax, |(t, _, _)| t.next_up());
            let Some((t, extra)) = hit(&self.primitives[id], limit) else { return f32::INFINITY };
            if let Some((best_t, best_id, _)) = best {
                if t == best_t && source[id] > source[best_id] {
                    return f32::INFINITY;
                }
            }
            best = Some((t, id, extra));
            // World to BVH units by a power of two: exact, so the culling distance is `t`.
            t * inv
        });
        best
    }

    /// The vertex attributes (OBJ `vt`, `vn`) of a primitive, if it is a mesh triangle that has
    /// them.
    #[inline]
    pub fn vertex_attributes(&self, primitive: u32) -> Option<&VertexAttributes> {
        let a = *self.attribute_index.get(primitive as usize)?;
        (a != NO_ATTRIBUTES).then(|| &self.attributes[a as usize])
    }

    /// The smooth dielectric objects (bounding spheres) manifold next-event estimation seeds
    /// its chains towards; empty in a scene without smooth glass.
    pub fn casters(&self) -> &[crate::manifold::Caster] {
        &self.casters
    }

    /// The material of a primitive.
    #[inline]
    pub fn material_of(&self, primitive: u32) -> &Material {
        &self.materials[self.primitives[primitive as usize].material as usize]
    }

    /// The object of the scene file a primitive belongs to (a mesh's triangles share one).
    #[inline]
    pub fn object_of(&self, primitive: u32) -> u32 {
        self.primitives[primitive as usize].object
    }

    /// The light a primitive emits for, if it is an emitter.
    #[inline]
    pub fn light_of(&self, primitive: u32) -> Option<u32> {
        self.primitives[primitive as usize].light
    }

    /// The sphere bounding every object: where light paths from the environment start.
    pub fn bounding_sphere(&self) -> SceneSphere {
        let (lo, hi) = self.bvh_stats.bounds;
        SceneSphere::around(lo, hi)
    }

    /// A distance from `p` beyond every object of the scene (for shadow rays to the environment).
    pub fn far_distance(&self, p: Vec3) -> f32 {
        let (lo, hi) = self.bvh_stats.bounds;
        2.0 * ((hi - lo).length() + (p - lo).length()) + 1.0
    }

    /// The radiance seen along a ray of unit direction `dir` that leaves the scene: the
    /// environment light's, or the background colour when there is none.
    #[inline]
    pub fn background(&self, dir: Vec3) -> Vec3 {
        match self.environment_light() {
            Some(i) => self.lights[i].environment_radiance(dir),
            None => self.settings.background,
        }
    }

    /// The index of the environment light, if the scene has one.
    pub fn environment_light(&self) -> Option<usize> {
        self.lights.iter().position(|l| matches!(l, Light::Environment { .. }))
    }
}
