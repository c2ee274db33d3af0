//! `vitrum info`: a scene's render settings, objects, materials, lights, BVH and effects, as
//! text or JSON.

use crate::commands::support::{load_scene, CliError};
use crate::integrators;
use crate::light::Strength;
use crate::scene::describe;
use crate::scene::effects::Support;
use serde_json::json;
use std::path::PathBuf;

/// Options of `vitrum info`.
#[derive(clap::Args, Debug)]
pub struct InfoArgs {
    /// Scene file (TOML); the embedded default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Print the same content as one JSON object (materials, textures and lights with their `kind`,
    /// a `description` as the text gives it, and their numbers as fields).
    #[arg(long)]
    pub json: bool,
}

/// Runs `vitrum info`.
pub fn run(args: &InfoArgs) -> Result<(), CliError> {
    let scene = load_scene(args.scene.as_deref())?;
    // Warnings go to stderr as for every command (and into the JSON with the scene's contents).
    for w in &scene.warnings {
        eprintln!("vitrum: warning: {w}");
    }
    let all = integrators::all();
    let support_text = |s: Support| match s {
        Support::Simulates => "simulates".to_string(),
        Support::Approximates(how) => format!("approximates: {how}"),
        Support::Ignores(how) => format!("ignores: {how}"),
    };
    let b = &scene.bvh_stats;
    // The engine `path` runs with the scene's own settings (`--engine auto`).
    let path = integrators::create("path").expect("path is registered");
    let engine = path.engine(&scene, &crate::render::RenderOptions::for_method(&scene, path.as_ref(), 1));
    if args.json {
        let effects: Vec<_> = scene
            .effects
            .0
            .iter()
            .map(|u| {
                let support: serde_json::Map<String, serde_json::Value> = all
                    .iter()
                    .map(|i| (i.name().to_string(), json!(support_text(i.support(u.effect)))))
                    .collect();
                json!({"effect": u.effect.name(), "reason": u.reason, "integrators": support})
            })
            .collect();
        let depths: serde_json::Map<String, serde_json::Value> = all
            .iter()
            .map(|i| {
                let from = if scene.settings.max_depths.contains_key(i.name()) { "scene" } else { "default" };
                // `null` for a method without a depth (`raycast` shades the first hit only).
                let depth = crate::scene::desc::has_max_depth(i.name())
                    .then(|| scene.settings.max_depth(i.as_ref(), None));
                let mut entry = json!({"max_depth": depth, "from": from});
                let merges = crate::scene::desc::MERGING_METHODS.contains(&i.name());
                if let Some(m) = scene.settings.merging.get(i.name()).filter(|_| merges) {
                    entry["radius"] = json!(integrators::initial_radius(&scene, m, None));
                    entry["radius_from"] = json!(if m.radius.is_some() { "scene" } else { "default" });
                    entry["radius_alpha"] = json!(m.alpha);
                }
                if let Some(m) = scene.settings.metropolis.get(i.name()) {
                    entry["large_step"] = json!(m.large_step);
                    entry["sigma"] = json!(m.sigma);
                    entry["bootstrap"] = json!(m.bootstrap);
                    entry["chains"] = json!(m.chains);
                }
                if i.method() == crate::methods::Method::Mnee {
                    let m = &scene.settings.manifold;
                    entry["seeding"] = json!(m.seeding.name());
                    entry["max_chain"] = json!(m.max_chain);
                    entry["max_trials"] = json!(m.max_trials);
                    entry["casters"] = json!(scene.casters().len());
                }
                (i.name().to_string(), entry)
            })
            .collect();
        let settings = &scene.settings;
        let summary = json!({
            "scene": scene.origin.name,
            "render": {"integrator": settings.integrator, "spp": settings.spp, "seed": settings.seed,
                       "spectral": settings.spectral.name(), "sampler": settings.sampler.name(), "methods": depths},
            "hash": scene.origin.hash,
            "resolution": [scene.camera.width, scene.camera.height],
            "camera": {
                "filter": scene.camera.filter.name(),
                "filter_radius": scene.camera.filter.radius(),
                "filter_parameters": scene.camera.filter.describe(),
                "filter_meaning": crate::pixel_filter::METHOD_MEANING,
                "near_clip": scene.camera.near_clip,
                "crop": [scene.camera.crop.x, scene.camera.crop.y, scene.camera.crop.width, scene.camera.crop.height],
            },
            "objects": scene.objects.iter().map(|o| json!({"name": o.name, "kind": o.kind, "material": o.material, "primitives": o.primitives, "texture_coordinates": o.mesh_attributes.0, "vertex_normals": o.mesh_attributes.1})).collect::<Vec<_>>(),
            "materials": scene.materials.iter().map(|m| {
                let mut d = describe::material(m).json();
                d["name"] = json!(m.name);
                d
            }).collect::<Vec<_>>(),
            "lights": scene.lights.iter().map(|l| {
                let mut d = describe::light(l).json();
                match l.strength() {
                    Strength::Power(p) => d["power_watts"] = json!(p.to_array()),
                    Strength::MeanRadiance(r) => d["mean_radiance"] = json!(r.to_array()),
                    Strength::Irradiance(e) => d["irradiance"] = json!(e.to_array()),
                }
                d
            }).collect::<Vec<_>>(),
            "bvh": {"nodes": b.nodes, "primitives": b.primitives, "depth": b.depth, "build_seconds": b.build_seconds,
                    "bounds_min": b.bounds.0.to_array(), "bounds_max": b.bounds.1.to_array()},
            "effects": effects,
            "path_engine": {"name": engine.name(), "description": engine.describe(), "reason": engine.reason},
            "warnings": scene.warnings,
        });
        println!("{summary}");
        return Ok(());
    }
    println!("scene      {} (hash {})", scene.origin.name, scene.origin.hash);
    let camera = &scene.camera;
    println!("camera     {}x{}, fov {}°", camera.width, camera.height, camera.fov_degrees);
    println!("filter     {}: {}", camera.filter.describe(), crate::pixel_filter::METHOD_MEANING);
    if camera.near_clip > 0.0 {
        println!("near clip  {} along the view axis", camera.near_clip);
    }
    let c = camera.crop;
    if (c.width, c.height) != (camera.width, camera.height) {
        println!("crop       {}x{} at ({}, {}): only these pixels are rendered", c.width, c.height, c.x, c.y);
    }
    let settings = &scene.settings;
    println!(
        "render     {}, {} spp, seed {}, spectral {}, sampler {}",
        settings.integrator,
        settings.spp,
        settings.seed,
        settings.spectral.name(),
        settings.sampler.name()
    );
    for i in &all {
        let from = if settings.max_depths.contains_key(i.name()) {
            "[render.".to_string() + i.name() + "]"
        } else {
            "default".into()
        };
        if crate::scene::desc::has_max_depth(i.name()) {
            print!("  {:<12} max depth {:<4} ({from})", i.name(), settings.max_depth(i.as_ref(), None));
        } else {
            print!("  {:<12} no depth (shades the first hit only)", i.name());
        }
        let merges = crate::scene::desc::MERGING_METHODS.contains(&i.name());
        if let Some(m) = settings.merging.get(i.name()).filter(|_| merges) {
            let r0 = integrators::initial_radius(&scene, m, None);
            let from = if m.radius.is_some() {
                "scene"
            } else {
                "default: a fraction of the scene's size, scaled to the pixel footprint over 256² pixels"
            };
            print!(", radius {r0:.4e} ({from}), radius alpha {}", m.alpha);
        }
        if let Some(m) = settings.metropolis.get(i.name()) {
            print!(
                ", large step {}, sigma {}, {} bootstrap samples and {} chains per sample index",
                m.large_step, m.sigma, m.bootstrap, m.chains
            );
        }
        if i.method() == crate::methods::Method::Mnee {
            let m = &settings.manifold;
            print!(
                ", {} seeds, chains of at most {} glass interfaces, at most {} trials, {} glass object(s) to chain through",
                m.seeding.name(),
                m.max_chain,
                m.max_trials,
                scene.casters().len()
            );
        }
        println!();
    }
    println!("objects    {}", scene.objects.len());
    for o in &scene.objects {
        let attributes = match o.mesh_attributes {
            (false, false) => "",
            (true, false) => ", with vt",
            (false, true) => ", with vn (smooth)",
            (true, true) => ", with vt and vn (smooth)",
        };
        println!(
            "  {:<24} {:<16} material {:<12} {} primitive(s){attributes}",
            o.name, o.kind, o.material, o.primitives
        );
    }
    println!("materials  {}", scene.materials.len());
    for m in &scene.materials {
        println!("  {:<24} {}", m.name, describe::material(m).text);
    }
    println!("lights     {}", scene.lights.len());
    for l in &scene.lights {
        // The environment's description gives its (mean) radiance already: it has no finite power.
        match l.strength() {
            Strength::Power(p) => println!("  {}, power {} W", describe::light(l).text, describe::vec3(p)),
            // A directional light's gives its irradiance: it has no finite power either.
            Strength::MeanRadiance(_) | Strength::Irradiance(_) => println!("  {}", describe::light(l).text),
        }
    }
    println!(
        "bvh        CwBvh, {} nodes, {} primitives, depth {}, built in {:.3} ms, bounds {} .. {}",
        b.nodes,
        b.primitives,
        b.depth,
        b.build_seconds * 1e3,
        describe::vec3(b.bounds.0),
        describe::vec3(b.bounds.1)
    );
    println!("path engine: {}", engine.describe());
    if scene.effects.0.is_empty() {
        println!("effects    none (every method renders this scene fully)");
    }
    for u in &scene.effects.0 {
        println!("effect     {}: {}", u.effect, u.reason);
        for i in &all {
            println!("  {:<12} {}", i.name(), support_text(i.support(u.effect)));
        }
    }
    Ok(())
}
