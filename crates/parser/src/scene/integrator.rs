//! The integrator and its parameters, AOVs included.

/// The integrator: which one, with its parameters (one parser file per plugin:
/// plugins/integrator/).
#[derive(Clone, Debug, PartialEq)]
pub struct Integrator {
    /// The plugin's type as written (`path`, `direct`, `volpath`, ...; a wrapper's inner one),
    /// for messages.
    pub type_name: String,
    pub kind: IntegratorKind,
    /// Mitsuba's `aov` integrator around it: the AOVs to write beside its image.
    pub aovs: Option<Aovs>,
}

/// Mitsuba's `aov` integrator: the arbitrary output variables it writes, each a per-pixel mean
/// over the camera rays' first hits, beside the image of the integrator it wraps.
#[derive(Clone, Debug, PartialEq)]
pub struct Aovs {
    /// The layer name of the wrapped integrator's image (its `name` attribute, Mitsuba's
    /// `_arg_0` without one); None when the `aov` wraps no integrator (its image is then black,
    /// as in Mitsuba).
    pub inner: Option<String>,
    /// In the order of the `aovs` string.
    pub list: Vec<Aov>,
}

/// One entry `name:type` of the `aovs` string.
#[derive(Clone, Debug, PartialEq)]
pub struct Aov {
    pub name: String,
    pub kind: AovKind,
}

/// The AOV types torrey writes (Mitsuba's, less `boundary_test`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AovKind {
    Albedo,
    Depth,
    Position,
    Uv,
    GeoNormal,
    ShNormal,
    DpDu,
    DpDv,
    DuvDx,
    DuvDy,
    PrimIndex,
    ShapeIndex,
}

impl AovKind {
    /// The type as the `aovs` string names it.
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "albedo" => AovKind::Albedo,
            "depth" => AovKind::Depth,
            "position" => AovKind::Position,
            "uv" => AovKind::Uv,
            "geo_normal" => AovKind::GeoNormal,
            "sh_normal" => AovKind::ShNormal,
            "dp_du" => AovKind::DpDu,
            "dp_dv" => AovKind::DpDv,
            "duv_dx" => AovKind::DuvDx,
            "duv_dy" => AovKind::DuvDy,
            "prim_index" => AovKind::PrimIndex,
            "shape_index" => AovKind::ShapeIndex,
            _ => return None,
        })
    }

    /// The channel suffixes Mitsuba gives the type: `name.T` for a depth, `name.X/Y/Z` for a
    /// position, ...
    pub fn suffixes(self) -> &'static [&'static str] {
        match self {
            AovKind::Albedo => &["R", "G", "B"],
            AovKind::Depth => &["T"],
            AovKind::Uv | AovKind::DuvDx | AovKind::DuvDy => &["U", "V"],
            AovKind::Position
            | AovKind::GeoNormal
            | AovKind::ShNormal
            | AovKind::DpDu
            | AovKind::DpDv => &["X", "Y", "Z"],
            AovKind::PrimIndex | AovKind::ShapeIndex => &["I"],
        }
    }
}

impl Aovs {
    /// The EXR channel names of the AOVs, in order (`dd.y:depth` gives `dd.y.T`).
    pub fn channel_names(&self) -> Vec<String> {
        self.list
            .iter()
            .flat_map(|a| a.kind.suffixes().iter().map(|s| format!("{}.{s}", a.name)))
            .collect()
    }
}

/// The integrators torrey renders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IntegratorKind {
    /// Mitsuba's `path`, and the types rendered by the path tracer.
    Path(PathParams),
    /// Mitsuba's `direct`.
    Direct(DirectParams),
    /// Mitsuba's `volpath` (`mis` false) and `volpathmis` (true): the path tracer with
    /// participating media; both converge to the same image.
    VolPath { params: PathParams, mis: bool },
}

/// The path tracer's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathParams {
    /// Mitsuba's `max_depth`: path segments; 1 = emitters seen directly, 2 = direct light,
    /// -1 = unbounded.
    pub max_depth: i32,
    /// Russian roulette starts at this depth (Mitsuba's `rr_depth`, default 5).
    pub rr_depth: i32,
    /// Mitsuba's `hide_emitters`: emitters seen directly by the camera are black.
    pub hide_emitters: bool,
}

/// `direct`'s parameters: emitter and BSDF samples per shading point (Mitsuba's
/// `emitter_samples`, `bsdf_samples`, both defaulting to `shading_samples`, 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectParams {
    pub emitter_samples: u32,
    pub bsdf_samples: u32,
    pub hide_emitters: bool,
}

impl Integrator {
    /// Path segments followed: `direct` follows two (the camera ray and one bounce).
    pub fn max_depth(&self) -> i32 {
        match self.kind {
            IntegratorKind::Path(p) | IntegratorKind::VolPath { params: p, .. } => p.max_depth,
            IntegratorKind::Direct(_) => 2,
        }
    }

    /// Where Russian roulette starts (`direct` never reaches it).
    pub fn rr_depth(&self) -> i32 {
        match self.kind {
            IntegratorKind::Path(p) | IntegratorKind::VolPath { params: p, .. } => p.rr_depth,
            IntegratorKind::Direct(_) => 5,
        }
    }

    pub fn hide_emitters(&self) -> bool {
        match self.kind {
            IntegratorKind::Path(p) | IntegratorKind::VolPath { params: p, .. } => p.hide_emitters,
            IntegratorKind::Direct(d) => d.hide_emitters,
        }
    }
}
