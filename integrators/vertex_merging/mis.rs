//! The multiple-importance weights of the bidirectional engine, in the recursive form of
//! Georgiev et al.'s technical report ("Implementing vertex connection and merging", 2012) with
//! the power heuristic: each sub-path carries three running quantities ([`Mis`]) from which the
//! weight of any strategy that ends at its last vertex follows in constant time. Every strategy's
//! weight is one function here, so that the engine and the test that the weights of all
//! strategies of a path sum to one use the same formulas.
//!
//! Densities are per unit solid angle unless named `_a` (per unit area). `k` holds the
//! iteration's constants: `mis_vm = mis(η)` and `mis_vc = mis(1/η)`, with `η = π r² N` the merge
//! kernel's area times the number of light paths (either is 0 when the method lacks the
//! strategy family).

use super::IterationConstants;

/// The power heuristic's term for a density (or ratio of densities).
#[inline]
pub(super) fn mis(x: f32) -> f32 {
    x * x
}

/// The running MIS quantities of a sub-path at its last vertex.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Mis {
    /// Reverse density of the vertex before the last over the forward density of the last.
    pub d_vcm: f32,
    /// The connection strategies' sum.
    pub d_vc: f32,
    /// The merging strategies' sum.
    pub d_vm: f32,
}

impl Mis {
    /// A camera sub-path whose first ray the camera samples with density `camera_pdf_w`, for an
    /// iteration of `paths` light sub-paths (light tracing's splats are normalised by it).
    pub fn camera(paths: f32, camera_pdf_w: f32) -> Mis {
        Mis { d_vcm: mis(paths / camera_pdf_w), d_vc: 0.0, d_vm: 0.0 }
    }

    /// A light sub-path emitted with the density `pdf_emit` (position and direction), whose
    /// point next-event estimation samples with `pdf_direct` (per area; the pick probability
    /// for a delta light), `cos_light` at the emitter; `delta`: a point light.
    pub fn light(k: &IterationConstants, pdf_emit: f32, pdf_direct: f32, cos_light: f32, delta: bool) -> Mis {
        let d_vc = if delta { 0.0 } else { mis(cos_light / pdf_emit) };
        Mis { d_vcm: mis(pdf_direct / pdf_emit), d_vc, d_vm: d_vc * k.mis_vc }
    }

    /// The update on reaching a surface at distance `t` with |cos| `cos` there.
    pub fn arrive(&mut self, t: f32, cos: f32) {
        self.d_vcm *= mis(t * t);
        self.arrive_from_infinity(cos);
    }

    /// The update on reaching a surface with |cos| `cos` there along the first segment of a
    /// light sub-path from the environment: the environment's densities are per solid angle
    /// already, so no squared distance converts them.
    pub fn arrive_from_infinity(&mut self, cos: f32) {
        let inv = 1.0 / mis(cos);
        self.d_vcm *= inv;
        self.d_vc *= inv;
        self.d_vm *= inv;
    }

    /// The update on scattering with |cos| `cos_out` into a direction of forward density `pdf`
    /// and reverse density `rev`; `evaluable: false` for a specular (or multiply scattered)
    /// sample, whose densities the other strategies cannot evaluate (ratio 1).
    pub fn scatter(&mut self, k: &IterationConstants, cos_out: f32, pdf: f32, rev: f32, evaluable: bool) {
        if evaluable {
            let g = mis(cos_out / pdf);
            self.d_vc = g * (self.d_vc * mis(rev) + self.d_vcm + k.mis_vm);
            self.d_vm = g * (self.d_vm * mis(rev) + self.d_vcm * k.mis_vc + 1.0);
            self.d_vcm = mis(1.0 / pdf);
        } else {
            self.d_vcm = 0.0;
            self.d_vc *= mis(cos_out);
            self.d_vm *= mis(cos_out);
        }
    }
}

/// The weight of a camera sub-path hitting an emitter, whose point next-event estimation picks
/// with `pick_direct_a` (per area) and light tracing emits with `pick_emit` (both times the
/// light's pick probability).
pub(super) fn emitter_hit(camera: &Mis, pick_direct_a: f32, pick_emit: f32) -> f32 {
    1.0 / (1.0 + (mis(pick_direct_a) * camera.d_vcm + mis(pick_emit) * camera.d_vc))
}

/// The weight of next-event estimation at the camera vertex `camera`: the BSDF samples the
/// light's direction with `bsdf_pdf` (0 for a delta light) and the reverse with `bsdf_rev`; the
/// light was sampled with `pick_direct` (per solid angle, times the pick probability; the
/// squared distance for a delta light); `emit_ratio` is the emission density over the direct
/// density, in the camera vertex's area measure, `pdf_emit·cos_camera / (pdf_direct·cos_light)`.
pub(super) fn next_event(
    camera: &Mis,
    k: &IterationConstants,
    bsdf_pdf: f32,
    bsdf_rev: f32,
    pick_direct: f32,
    emit_ratio: f32,
) -> f32 {
    let w_light = mis(bsdf_pdf / pick_direct);
    let w_camera = mis(emit_ratio) * (k.mis_vm + camera.d_vcm + camera.d_vc * mis(bsdf_rev));
    1.0 / (w_light + 1.0 + w_camera)
}

/// The weight of connecting the camera vertex `camera` to the light vertex `light`: each
/// vertex's BSDF samples the other with the area densities `camera_dir_a` and `light_dir_a`,
/// and reverses its own incoming direction with `camera_rev` and `light_rev`.
pub(super) fn connection(
    camera: &Mis,
    light: &Mis,
    k: &IterationConstants,
    camera_dir_a: f32,
    light_dir_a: f32,
    camera_rev: f32,
    light_rev: f32,
) -> f32 {
    let w_light = mis(camera_dir_a) * (k.mis_vm + light.d_vcm + light.d_vc * mis(light_rev));
    let w_camera = mis(light_dir_a) * (k.mis_vm + camera.d_vcm + camera.d_vc * mis(camera_rev));
    1.0 / (w_light + 1.0 + w_camera)
}

/// The weight of connecting the light vertex `light` to the camera, which samples that vertex
/// with the area density `camera_pdf_a` (per light path: divided by their number); `rev` the
/// reverse density of the light vertex's incoming direction.
pub(super) fn camera_splat(light: &Mis, k: &IterationConstants, camera_pdf_a_per_path: f32, rev: f32) -> f32 {
    1.0 / (1.0 + mis(camera_pdf_a_per_path) * (k.mis_vm + light.d_vcm + light.d_vc * mis(rev)))
}

/// The weight of merging the camera vertex `camera` with the photon `light`: the camera
/// vertex's BSDF samples the photon's incoming direction with `dir` and reverses its own with
/// `rev`.
pub(super) fn merge(camera: &Mis, light: &Mis, k: &IterationConstants, dir: f32, rev: f32) -> f32 {
    let w_light = light.d_vcm * k.mis_vc + light.d_vm * mis(dir);
    let w_camera = camera.d_vcm * k.mis_vc + camera.d_vm * mis(rev);
    1.0 / (w_light + 1.0 + w_camera)
}

#[cfg(test)]
mod tests {
    //! For random paths, the weights of all strategies that can make the same path sum to one:
    //! the path's vertices, their densities and the sub-path quantities are computed here from
    //! the geometry, for diffuse (Lambert) and specular vertices, area and point lights and the
    //! environment, with and without merging.
    use super::*;
    use glam::Vec3;
    use rand::{RngExt, SeedableRng};
    use std::f32::consts::PI;

    const PATHS: f32 = 4096.0;
    const PIXEL_AREA: f32 = 2e-4;
    const LIGHT_AREA: f32 = 0.3;
    /// `1/(π R²)` of the environment's bounding disk.
    const DISK_PDF: f32 = 1.0 / (PI * 9.0);
    /// Next-event estimation's solid-angle density of an environment direction.
    const ENV_DIRECT: f32 = 1.0 / (4.0 * PI);

    /// What the path's last vertex is on.
    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Emitter {
        Area,
        Point,
        /// The environment: the last "vertex" is one unit along the direction the light comes from.
        Environment,
    }

    /// A full path x₀ (camera) … x_last (on the light).
    struct FullPath {
        p: Vec<Vec3>,
        n: Vec<Vec3>,
        specular: Vec<bool>,
        forward: Vec3,
        emitter: Emitter,
    }

    impl FullPath {
        fn random(rng: &mut rand_pcg::Pcg64, vertices: usize, emitter: Emitter, specular: f64) -> FullPath {
            let mut v3 =
                |s: f32| Vec3::new(rng.random_range(-s..s), rng.random_range(-s..s), rng.random_range(-s..s));
            let mut p: Vec<Vec3> =
                (0..vertices).map(|i| Vec3::new(i as f32 * 0.7, 0.0, 0.0) + v3(0.5)).collect();
            let last = vertices - 1;
            if emitter == Emitter::Environment {
                p[last] = p[last - 1] + (p[last] - p[last - 1]).normalize();
            }
            let mut n = vec![Vec3::Z; vertices];
            for i in 1..last {
                // Facing both neighbours (every cosine positive), tilted at random.
                let mid = ((p[i - 1] - p[i]).normalize() + (p[i + 1] - p[i]).normalize()).normalize();
                n[i] = (mid + v3(0.4)).normalize();
                if n[i].dot(p[i - 1] - p[i]) <= 0.0 || n[i].dot(p[i + 1] - p[i]) <= 0.0 {
                    n[i] = mid;
                }
            }
            n[last] = ((p[last - 1] - p[last]).normalize() + v3(0.3)).normalize();
            if n[last].dot(p[last - 1] - p[last]) <= 0.0 {
                n[last] = (p[last - 1] - p[last]).normalize();
            }
            let forward = ((p[1] - p[0]).normalize() + v3(0.2)).normalize();
            let specular = (0..vertices).map(|i| i > 0 && i < last && rng.random_bool(specular)).collect();
            FullPath { p, n, specular, forward, emitter }
        }

        fn last(&self) -> usize {
            self.p.len() - 1
        }

        fn dist2(&self, i: usize, j: usize) -> f32 {
            (self.p[j] - self.p[i]).length_squared()
        }

        fn cos(&self, i: usize, towards: usize) -> f32 {
            self.n[i].dot((self.p[towards] - self.p[i]).normalize()).abs()
        }

        /// The BSDF density at vertex `i` of the direction towards `j` (Lambert; 1 stands for a
        /// specular vertex, whose densities are never used).
        fn pdf(&self, i: usize, j: usize) -> f32 {
            if self.specular[i] {
                1.0
            } else {
                self.cos(i, j) / PI
            }
        }

        fn diffuse(&self, i: usize) -> bool {
            !self.specular[i]
        }

        fn camera_pdf_w(&self) -> f32 {
            let c = self.forward.dot((self.p[1] - self.p[0]).normalize());
            1.0 / (PIXEL_AREA * c * c * c)
        }

        /// The camera sub-path's quantities on arriving at vertex `t`.
        fn camera_mis(&self, k: &IterationConstants, t: usize) -> Mis {
            let mut m = Mis::camera(PATHS, self.camera_pdf_w());
            for i in 1..=t {
                m.arrive(self.dist2(i - 1, i).sqrt(), self.cos(i, i - 1));
                if i < t {
                    m.scatter(k, self.cos(i, i + 1), self.pdf(i, i + 1), self.pdf(i, i - 1), self.diffuse(i));
                }
            }
            m
        }

        /// The camera sub-path's quantities on leaving the scene towards the environment.
        fn camera_mis_escaped(&self, k: &IterationConstants) -> Mis {
            let c = self.last() - 1;
            let mut m = self.camera_mis(k, c);
            m.scatter(k, self.cos(c, c + 1), self.pdf(c, c + 1), self.pdf(c, c - 1), self.diffuse(c));
            m
        }

        /// The light sub-path's quantities on arriving at vertex `j` (< last).
        fn light_mis(&self, k: &IterationConstants, j: usize) -> Mis {
            let last = self.last();
            let mut m = match self.emitter {
                Emitter::Point => Mis::light(k, 1.0 / (4.0 * PI), 1.0, 1.0, true),
                Emitter::Area => {
                    let c = self.cos(last, last - 1);
                    Mis::light(k, c / (PI * LIGHT_AREA), 1.0 / LIGHT_AREA, c, false)
                }
                Emitter::Environment => Mis::light(k, ENV_DIRECT * DISK_PDF, ENV_DIRECT, 1.0, false),
            };
            for i in (j..last).rev() {
                if i + 1 == last && self.emitter == Emitter::Environment {
                    m.arrive_from_infinity(self.cos(i, i + 1));
                } else {
                    m.arrive(self.dist2(i + 1, i).sqrt(), self.cos(i, i + 1));
                }
                if i > j {
                    m.scatter(k, self.cos(i, i - 1), self.pdf(i, i - 1), self.pdf(i, i + 1), self.diffuse(i));
                }
            }
            m
        }

        /// The weights of every strategy that makes this path, by name. Without connections
        /// (`bpm`) an emitter hit counts only after a purely specular chain (as the engine
        /// rules), merges make the rest.
        fn weights(&self, k: &IterationConstants, merging: bool, connecting: bool) -> Vec<(String, f32)> {
            let last = self.last();
            let mut w = Vec::new();
            if self.emitter != Emitter::Point {
                let weight = if connecting && self.emitter == Emitter::Environment {
                    emitter_hit(&self.camera_mis_escaped(k), ENV_DIRECT, ENV_DIRECT * DISK_PDF)
                } else if connecting {
                    let c = self.cos(last, last - 1);
                    emitter_hit(&self.camera_mis(k, last), 1.0 / LIGHT_AREA, c / (PI * LIGHT_AREA))
                } else if (1..last).all(|i| self.specular[i]) {
                    1.0
                } else {
                    0.0
                };
                w.push(("emitter hit".into(), weight));
            }
            if !connecting {
                if merging {
                    for i in (1..last).filter(|&i| self.diffuse(i)) {
                        let (cam, light) = (self.camera_mis(k, i), self.light_mis(k, i));
                        let weight = merge(&cam, &light, k, self.pdf(i, i + 1), self.pdf(i, i - 1));
                        w.push((format!("merge at {i}"), weight));
                    }
                }
                return w;
            }
            let c = last - 1;
            if self.diffuse(c) {
                let m = self.camera_mis(k, c);
                let d2 = self.dist2(c, last);
                let (bsdf_pdf, pick_direct, emit_ratio) = if self.emitter == Emitter::Point {
                    (0.0, d2, self.cos(c, last) / (4.0 * PI * d2))
                } else if self.emitter == Emitter::Environment {
                    (self.pdf(c, last), ENV_DIRECT, ENV_DIRECT * DISK_PDF * self.cos(c, last) / ENV_DIRECT)
                } else {
                    let cos_l = self.cos(last, c);
                    let direct = d2 / (LIGHT_AREA * cos_l);
                    (
                        self.pdf(c, last),
                        direct,
                        cos_l / (PI * LIGHT_AREA) * self.cos(c, last) / (direct * cos_l),
                    )
                };
                w.push((
                    "next event".into(),
                    next_event(&m, k, bsdf_pdf, self.pdf(c, c - 1), pick_direct, emit_ratio),
                ));
            }
            for t in 1..last.saturating_sub(1) {
                let j = t + 1;
                if self.diffuse(t) && self.diffuse(j) {
                    let d2 = self.dist2(t, j);
                    let camera_dir_a = self.pdf(t, j) * self.cos(j, t) / d2;
                    let light_dir_a = self.pdf(j, t) * self.cos(t, j) / d2;
                    let (cam, light) = (self.camera_mis(k, t), self.light_mis(k, j));
                    let weight = connection(
                        &cam,
                        &light,
                        k,
                        camera_dir_a,
                        light_dir_a,
                        self.pdf(t, t - 1),
                        self.pdf(j, j + 1),
                    );
                    w.push((format!("connection {t}-{j}"), weight));
                }
            }
            if self.diffuse(1) {
                let c = self.forward.dot((self.p[1] - self.p[0]).normalize());
                let camera_pdf_a = self.cos(1, 0) / (PIXEL_AREA * self.dist2(0, 1) * c * c * c);
                let weight = camera_splat(&self.light_mis(k, 1), k, camera_pdf_a / PATHS, self.pdf(1, 2));
                w.push(("camera splat".into(), weight));
            }
            if merging {
                for i in (1..last).filter(|&i| self.diffuse(i)) {
                    let (cam, light) = (self.camera_mis(k, i), self.light_mis(k, i));
                    w.push((
                        format!("merge at {i}"),
                        merge(&cam, &light, k, self.pdf(i, i + 1), self.pdf(i, i - 1)),
                    ));
                }
            }
            w
        }
    }

    fn constants(merging: bool, connecting: bool, radius: f32) -> IterationConstants {
        let eta = PI * radius * radius * PATHS;
        IterationConstants {
            radius,
            mis_vm: if merging { mis(eta) } else { 0.0 },
            mis_vc: if connecting { mis(1.0 / eta) } else { 0.0 },
            vm_norm: 1.0 / eta,
        }
    }

    #[test]
    fn the_weights_of_all_strategies_of_a_path_sum_to_one() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let mut checked = 0;
        for case in 0..400 {
            let vertices = 3 + case % 5;
            let emitter = [Emitter::Point, Emitter::Area, Emitter::Environment][case % 3];
            let specular = if case % 4 == 0 { 0.0 } else { 0.35 };
            let path = FullPath::random(&mut rng, vertices, emitter, specular);
            // bpt (connections only), vcm (connections and merges) at two radii, bpm (merges only).
            for (name, merging, connecting, radius) in [
                ("bpt", false, true, 0.01),
                ("vcm", true, true, 0.01),
                ("vcm", true, true, 0.1),
                ("bpm", true, false, 0.02),
            ] {
                let k = constants(merging, connecting, radius);
                let strategies = path.weights(&k, merging, connecting);
                if strategies.is_empty() {
                    continue; // a point light and only specular vertices: no strategy at all
                }
                let sum: f32 = strategies.iter().map(|(_, w)| w).sum();
                assert!(
                    (sum - 1.0).abs() < 1e-4,
                    "{name} (r {radius}), {vertices} vertices, {emitter:?}, specular {:?}: \
                     weights {strategies:?} sum to {sum}",
                    path.specular
                );
                assert!(strategies.iter().all(|(_, w)| (0.0..=1.0).contains(w)));
                checked += 1;
            }
        }
        assert!(checked > 1000, "{checked} paths checked");
    }
}
