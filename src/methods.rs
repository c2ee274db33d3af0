//! The table of rendering methods: each method's name, one-line description, default depth and
//! the settings its `[render.METHOD]` table takes, written once. The command line (`vitrum
//! integrators`, `--integrator`), the scene format (the `[render.METHOD]` tables, `[render]
//! integrator`), the registry of constructors ([`crate::integrators::create`]) and the tests all
//! read it. It is data only and imports nothing of the crate, so every layer can read it.

/// A rendering method, in the order `vitrum integrators` lists them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Method {
    /// Ray casting.
    RayCast,
    /// Whitted ray tracing.
    Whitted,
    /// Supersampled antialiasing over Whitted radiance.
    Ssaa,
    /// Distributed ray tracing.
    Distributed,
    /// Path tracing.
    Path,
    /// Light tracing.
    Light,
    /// Bidirectional path tracing.
    Bpt,
    /// Progressive photon mapping.
    Ppm,
    /// Bidirectional photon mapping.
    Bpm,
    /// Vertex connection and merging.
    Vcm,
    /// Primary-sample-space Metropolis light transport over path tracing.
    Pssmlt,
    /// Multiplexed Metropolis light transport over the bidirectional engine's strategies.
    Mmlt,
    /// Path tracing with manifold next-event estimation through glass.
    Mnee,
}

/// What a method's `[render.METHOD]` table takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Settings {
    /// Nothing: the table must be empty (`raycast` shades the first hit only, it has no depth).
    None,
    /// `max_depth`.
    Depth,
    /// `max_depth` and the supersampling pattern (`mode`, `grid`, `levels`, `threshold`).
    Supersampling,
    /// `max_depth` and the merge radius (`radius`, `radius_alpha`, ...): the methods that merge
    /// photons.
    Merging,
    /// `max_depth` and the Metropolis settings (`large_step`, `sigma`, `bootstrap`, `chains`).
    Metropolis,
    /// `max_depth` and the manifold settings (`seeding`, `max_chain`, `max_trials`).
    Manifold,
}

/// One row of the table of methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MethodInfo {
    /// The method.
    pub method: Method,
    /// Its name in scene files and on the command line.
    pub name: &'static str,
    /// One line for `vitrum integrators`.
    pub description: &'static str,
    /// The maximum depth when neither the scene nor the command line sets one.
    pub default_max_depth: u32,
    /// What its `[render.METHOD]` table takes.
    pub settings: Settings,
}

/// Deepest recursion the renderer accepts, the largest maximum depth a scene or the command line
/// may set (bounded stack; deeper paths carry no visible light).
pub const MAX_DEPTH: u32 = 256;

/// The default maximum depth of `path`, `light` and the bidirectional methods (bounces): the
/// largest allowed. Rough glass traps light by total internal reflection for hundreds of bounces
/// (a glass sphere of roughness 0.2 in a white furnace renders 0.9968 when paths stop at 64,
/// 1.0000 at 256), and Russian roulette rightly spares such lossless paths, so only a depth
/// limit ends them; the few that go deep cost little.
pub const DEFAULT_PATH_DEPTH: u32 = MAX_DEPTH;

/// The default maximum depth of `mmlt`: its state space has one part per path depth, each
/// bootstrapped and explored without Russian roulette, so its cost grows with the depth
/// (a depth-`d` sample traces `d + 1` segments). At 16 a closed room of albedo 0.75 loses
/// 0.75¹⁶ ≈ 1% of its light; a scene or `--max-depth` may set up to 256.
pub const DEFAULT_MMLT_DEPTH: u32 = 16;

/// The default depth of the recursive ray tracers (`whitted`, `ssaa`, `distributed`).
pub const DEFAULT_RECURSION_DEPTH: u32 = 5;

/// Every method, in the order of [`Method`].
pub const METHODS: [MethodInfo; 13] = [
    MethodInfo {
        method: Method::RayCast,
        name: "raycast",
        description: "ray casting: first hit, Phong shading, hard shadows; glass shows only its surface",
        default_max_depth: DEFAULT_RECURSION_DEPTH,
        settings: Settings::None,
    },
    MethodInfo {
        method: Method::Whitted,
        name: "whitted",
        description: "Whitted ray tracing: recursive reflection and refraction, Fresnel, shadows through glass; no caustics",
        default_max_depth: DEFAULT_RECURSION_DEPTH,
        settings: Settings::Depth,
    },
    MethodInfo {
        method: Method::Ssaa,
        name: "ssaa",
        description: "supersampled antialiasing over Whitted radiance: regular n×n grid or adaptive corner subdivision",
        default_max_depth: DEFAULT_RECURSION_DEPTH,
        settings: Settings::Supersampling,
    },
    MethodInfo {
        method: Method::Distributed,
        name: "distributed",
        description: "distributed ray tracing (Cook 1984): soft shadows, glossy/frosted, depth of field, motion blur, dispersion",
        default_max_depth: DEFAULT_RECURSION_DEPTH,
        settings: Settings::Depth,
    },
    MethodInfo {
        method: Method::Path,
        name: "path",
        description: "Monte Carlo path tracing: next-event estimation + MIS, specular chains, Russian roulette; the reference",
        default_max_depth: DEFAULT_PATH_DEPTH,
        settings: Settings::Depth,
    },
    MethodInfo {
        method: Method::Light,
        name: "light",
        description: "light tracing: light paths splat into the film; caustics from any light; smooth mirrors/glass black",
        default_max_depth: DEFAULT_PATH_DEPTH,
        settings: Settings::Depth,
    },
    MethodInfo {
        method: Method::Bpt,
        name: "bpt",
        description: "bidirectional path tracing: camera and light sub-paths connected, MIS over every strategy",
        default_max_depth: DEFAULT_PATH_DEPTH,
        settings: Settings::Depth,
    },
    MethodInfo {
        method: Method::Ppm,
        name: "ppm",
        description: "progressive photon mapping: specular camera chains merge photons once; radius shrinks",
        default_max_depth: DEFAULT_PATH_DEPTH,
        settings: Settings::Merging,
    },
    MethodInfo {
        method: Method::Bpm,
        name: "bpm",
        description: "bidirectional photon mapping: merges at every non-specular camera vertex, MIS",
        default_max_depth: DEFAULT_PATH_DEPTH,
        settings: Settings::Merging,
    },
    MethodInfo {
        method: Method::Vcm,
        name: "vcm",
        description: "vertex connection and merging: bpt plus merging, MIS over both; every light path",
        default_max_depth: DEFAULT_PATH_DEPTH,
        settings: Settings::Merging,
    },
    MethodInfo {
        method: Method::Pssmlt,
        name: "pssmlt",
        description: "primary-sample-space Metropolis (Kelemen 2002) over path: chains mutate path's random numbers",
        default_max_depth: DEFAULT_PATH_DEPTH,
        settings: Settings::Metropolis,
    },
    MethodInfo {
        method: Method::Mmlt,
        name: "mmlt",
        description: "multiplexed Metropolis (Hachisuka 2014) over bpt's strategies: one chain space per path depth",
        default_max_depth: DEFAULT_MMLT_DEPTH,
        settings: Settings::Metropolis,
    },
    MethodInfo {
        method: Method::Mnee,
        name: "mnee",
        description: "path with manifold next-event estimation: Newton-solved chains through glass to lights",
        default_max_depth: DEFAULT_PATH_DEPTH,
        settings: Settings::Manifold,
    },
];

/// The names of [`METHODS`], in order.
pub const NAMES: [&str; METHODS.len()] = {
    let mut names = [""; METHODS.len()];
    let mut i = 0;
    while i < METHODS.len() {
        names[i] = METHODS[i].name;
        i += 1;
    }
    names
};

/// The number of methods whose settings are `settings`.
const fn count(settings: Settings) -> usize {
    let (mut n, mut i) = (0, 0);
    while i < METHODS.len() {
        n += (METHODS[i].settings as usize == settings as usize) as usize;
        i += 1;
    }
    n
}

/// The names of the methods that merge photons ([`Settings::Merging`]), in order.
pub const MERGING_NAMES: [&str; count(Settings::Merging)] = {
    let mut names = [""; count(Settings::Merging)];
    let (mut i, mut k) = (0, 0);
    while i < METHODS.len() {
        if METHODS[i].settings as usize == Settings::Merging as usize {
            names[k] = METHODS[i].name;
            k += 1;
        }
        i += 1;
    }
    names
};

impl Method {
    /// Every method, in table order.
    pub const ALL: [Method; METHODS.len()] = {
        let mut all = [Method::RayCast; METHODS.len()];
        let mut i = 0;
        while i < METHODS.len() {
            all[i] = METHODS[i].method;
            i += 1;
        }
        all
    };

    /// The method named `name`, if any.
    pub fn from_name(name: &str) -> Option<Method> {
        METHODS.iter().find(|m| m.name == name).map(|m| m.method)
    }

    /// Its row of the table.
    pub const fn info(self) -> &'static MethodInfo {
        &METHODS[self as usize]
    }

    /// Its name in scene files and on the command line.
    pub const fn name(self) -> &'static str {
        self.info().name
    }

    /// Whether it has a maximum depth (`[render.NAME] max_depth`): every method but `raycast`.
    pub const fn has_max_depth(self) -> bool {
        !matches!(self.info().settings, Settings::None)
    }

    /// Whether its depth counts recursion levels that gather light at their last hit (Whitted's
    /// family: `whitted`, `ssaa`, `distributed`) rather than the bounces of a path.
    pub const fn recursive(self) -> bool {
        matches!(self, Method::Whitted | Method::Ssaa | Method::Distributed)
    }

    /// Whether it merges photons, and so takes a merge radius.
    pub const fn merges(self) -> bool {
        matches!(self.info().settings, Settings::Merging)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_row_is_at_the_place_of_its_method_and_names_are_unique() {
        for (i, row) in METHODS.iter().enumerate() {
            assert_eq!(row.method as usize, i, "{}", row.name);
            assert_eq!(Method::from_name(row.name), Some(row.method));
            assert_eq!(Method::ALL[i].name(), NAMES[i]);
        }
        assert_eq!(MERGING_NAMES, ["ppm", "bpm", "vcm"]);
        assert_eq!(Method::from_name("Path"), None, "names are case-sensitive");
        assert!(!Method::RayCast.has_max_depth() && Method::Whitted.has_max_depth());
    }
}
