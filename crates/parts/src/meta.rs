//! What a part is: the scene, the settings and the slice, as recorded in its EXR header.

use torrey_renderer::{RenderSettings, SamplerKind};

/// The identity of a render part. Parts merge when their scene hash, settings, film size and spp
/// agree; their crops and sample ranges then say where their pixels and samples go.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PartMeta {
    /// The scene file as the renderer was given it (for people; parts from copies of a scene
    /// in other folders still merge).
    pub scene: String,
    /// [`crate::scene_hash`] of the scene's contents.
    pub scene_hash: String,
    /// [`settings_text`] of the render settings.
    pub settings: String,
    /// The full film, in pixels.
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// The global sample indices this part holds: `first..end`.
    pub samples: (u32, u32),
    /// The film window this part holds: `(x, y, width, height)`.
    pub crop: (u32, u32, u32, u32),
    /// Samples that were NaN or infinite and were dropped (counted as zero).
    pub nonfinite: u64,
    /// Pixels whose mean or variance exceeded f32's range and was clamped to it (in the render
    /// of each part, and in the merge; `RenderOutput::clamped_pixels`).
    pub clamped: u64,
}

/// The render settings that decide pixels, as one canonical line (`key=value` pairs): parts
/// whose lines differ do not belong together. Film size and spp are kept in their own fields;
/// thread count, tile size, BVH width and ray packets do not change pixels and are left out (and
/// so is a time limit: each part's per-pixel counts say what it holds).
pub fn settings_text(s: &RenderSettings) -> String {
    let sampler = match s.sampler {
        SamplerKind::Sobol => "sobol",
        SamplerKind::Independent => "independent",
    };
    let mut text = format!(
        "seed={} max_depth={} rr_depth={} sampler={} filter={:?} mipmap={} env={:?}",
        s.seed,
        s.integrator.max_depth(),
        s.integrator.rr_depth(),
        sampler,
        s.filter,
        s.mipmapping,
        s.env_strategy
    );
    // Adaptive sampling decides which samples a pixel has (a time limit only how many passes
    // ran, which the per-pixel counts record).
    if let Some(t) = s.noise_threshold {
        text += &format!(" noise_threshold={t}");
    }
    text
}

const SCENE: &str = "torrey.scene";
const HASH: &str = "torrey.sceneHash";
const SETTINGS: &str = "torrey.settings";
const FILM: &str = "torrey.film";
const SPP: &str = "torrey.spp";
const SAMPLES: &str = "torrey.sampleRange";
const CROP: &str = "torrey.crop";
const NONFINITE: &str = "torrey.nonfiniteSamples";
const CLAMPED: &str = "torrey.clampedPixels";

impl PartMeta {
    /// The EXR header attributes (all text) that record this part.
    pub fn attributes(&self) -> Vec<(&'static str, String)> {
        let (x, y, w, h) = self.crop;
        vec![
            (SCENE, self.scene.clone()),
            (HASH, self.scene_hash.clone()),
            (SETTINGS, self.settings.clone()),
            (FILM, format!("{}x{}", self.width, self.height)),
            (SPP, self.spp.to_string()),
            (SAMPLES, format!("{}..{}", self.samples.0, self.samples.1)),
            (CROP, format!("{x},{y},{w},{h}")),
            (NONFINITE, self.nonfinite.to_string()),
            (CLAMPED, self.clamped.to_string()),
        ]
    }

    /// Reads the attributes back; `get(name)` gives a text attribute. An EXR without them was not
    /// written by a torrey render.
    pub fn from_attributes(get: impl Fn(&str) -> Option<String>) -> Result<Self, String> {
        let need = |name: &str| {
            get(name).ok_or_else(|| {
                format!("no '{name}' attribute: not a torrey render part (or written by an older torrey)")
            })
        };
        let bad = |name: &str, v: &str| format!("bad '{name}' attribute '{v}'");
        let num = |name: &str| -> Result<u64, String> {
            let v = need(name)?;
            v.trim().parse().map_err(|_| bad(name, &v))
        };
        let film = need(FILM)?;
        let (width, height) = film
            .split_once('x')
            .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
            .ok_or_else(|| bad(FILM, &film))?;
        let samples_text = need(SAMPLES)?;
        let samples = samples_text
            .split_once("..")
            .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))
            .ok_or_else(|| bad(SAMPLES, &samples_text))?;
        let crop_text = need(CROP)?;
        let c: Vec<u32> = crop_text
            .split(',')
            .map(|v| v.trim().parse())
            .collect::<Result<_, _>>()
            .map_err(|_| bad(CROP, &crop_text))?;
        let [x, y, w, h] = c[..] else {
            return Err(bad(CROP, &crop_text));
        };
        let spp = u32::try_from(num(SPP)?).map_err(|_| bad(SPP, "too large"))?;
        Ok(PartMeta {
            scene: need(SCENE)?,
            scene_hash: need(HASH)?,
            settings: need(SETTINGS)?,
            width,
            height,
            spp,
            samples,
            crop: (x, y, w, h),
            nonfinite: num(NONFINITE)?,
            // Parts written before the count existed have none.
            clamped: match get(CLAMPED) {
                Some(_) => num(CLAMPED)?,
                None => 0,
            },
        })
    }

    /// Why `self` and `other` cannot be parts of one render, if they cannot.
    pub fn mismatch(&self, other: &PartMeta) -> Option<String> {
        if self.scene_hash != other.scene_hash {
            return Some(format!(
                "other scene contents (hash {} of {} vs {} of {})",
                other.scene_hash, other.scene, self.scene_hash, self.scene
            ));
        }
        if self.settings != other.settings {
            return Some(format!(
                "other settings ('{}' vs '{}')",
                other.settings, self.settings
            ));
        }
        if (self.width, self.height) != (other.width, other.height) {
            return Some(format!(
                "other film size ({}x{} vs {}x{})",
                other.width, other.height, self.width, self.height
            ));
        }
        if self.spp != other.spp {
            return Some(format!("other spp ({} vs {})", other.spp, self.spp));
        }
        None
    }
}
