//! `torrey._native`: the Rust side of the `torrey` Python package. The Python side
//! (`torrey/__init__.py`) turns its byte buffers into numpy arrays and documents the API.
//!
//! Rendering releases the GIL; the progress callback takes it back for each call, from whichever
//! render thread finished a tile.

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use torrey_parts::{Part, PartMeta};
use torrey_renderer::{Overrides, RenderScene, RenderSettings, RenderSlice, SamplerKind};

// Registered as `torrey.SceneError` (the package re-exports it), so it pickles by reference: a
// Ray task's scene error reaches the driver as itself.
create_exception!(
    torrey,
    SceneError,
    PyValueError,
    "A scene that cannot be read or built; `file`, `line` and `column` say where."
);

/// A `SceneError` with `file`, `line`, `column` attributes from a `file:line:column: ...`
/// message (the format of every torrey scene error).
fn scene_error(message: String) -> PyErr {
    let err = SceneError::new_err(message.clone());
    let location = message
        .split_once(": error: ")
        .map(|(loc, _)| loc.to_string());
    Python::attach(|py| {
        let value = err.value(py);
        let (mut file, mut line, mut column) = (None, None, None);
        if let Some(loc) = location {
            let mut it = loc.rsplitn(3, ':');
            if let (Some(c), Some(l), Some(f)) = (it.next(), it.next(), it.next()) {
                if let (Ok(l), Ok(c)) = (l.parse::<u32>(), c.parse::<u32>()) {
                    (file, line, column) = (Some(f.to_string()), Some(l), Some(c));
                }
            }
        }
        let _ = value.setattr("file", file);
        let _ = value.setattr("line", line);
        let _ = value.setattr("column", column);
    });
    err
}

/// A film size and the render scene built for it.
type Built = Option<((u32, u32), Arc<RenderScene>)>;

/// A parsed scene (meshes loaded), with its last built acceleration structure kept for the
/// next render of the same size.
#[pyclass(frozen, module = "torrey._native")]
struct Scene {
    desc: Arc<torrey_parser::Scene>,
    defines: Vec<(String, String)>,
    hash: String,
    built: Mutex<Built>,
}

#[pymethods]
impl Scene {
    /// The scene file.
    #[getter]
    fn path(&self) -> String {
        self.desc.path.display().to_string()
    }
    /// Every file the scene names (meshes, images), resolved.
    #[getter]
    fn files(&self) -> Vec<String> {
        self.desc
            .files
            .iter()
            .map(|f| f.display().to_string())
            .collect()
    }
    /// The `<default>` overrides it was loaded with.
    #[getter]
    fn defines(&self) -> Vec<(String, String)> {
        self.defines.clone()
    }
    /// Hash of the scene file, its defines and the files it names.
    #[getter]
    fn content_hash(&self) -> String {
        self.hash.clone()
    }
    /// The film size (width, height) the scene asks for.
    #[getter]
    fn size(&self) -> (u32, u32) {
        (self.desc.film.width, self.desc.film.height)
    }
    /// The film's crop window (x, y, width, height), if it sets one (Mitsuba's crop parameters).
    #[getter]
    fn crop(&self) -> Option<(u32, u32, u32, u32)> {
        self.desc.film.crop.map(|c| c.rect())
    }
    /// The scene's sample count.
    #[getter]
    fn spp(&self) -> u32 {
        self.desc.sampler.sample_count
    }
    /// The scene's sampler seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.desc.sampler.seed
    }
    /// The scene's maximum path depth (Mitsuba's convention).
    #[getter]
    fn max_depth(&self) -> i32 {
        self.desc.integrator.max_depth()
    }
    /// Warnings about harmless oddities, as `file:line:column: warning: ...` lines.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.desc.warnings.iter().map(|w| w.to_string()).collect()
    }
    fn __repr__(&self) -> String {
        format!("<torrey.Scene {}>", self.desc.path.display())
    }
}

impl Scene {
    /// The render scene for a film size, built once and kept.
    fn render_scene(&self, size: (u32, u32)) -> Result<Arc<RenderScene>, String> {
        let mut built = self.built.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((s, rs)) = built.as_ref() {
            if *s == size {
                return Ok(rs.clone());
            }
        }
        let rs =
            Arc::new(RenderScene::build(&self.desc, size.0, size.1).map_err(|e| e.to_string())?);
        *built = Some((size, rs.clone()));
        Ok(rs)
    }
}

/// Reads a scene file; `defines` are `<default>` overrides, as the command line's `-D`.
#[pyfunction]
#[pyo3(signature = (path, defines))]
fn load_file(py: Python<'_>, path: PathBuf, defines: Vec<(String, String)>) -> PyResult<Scene> {
    let (desc, hash) = py
        .detach(|| {
            let desc = torrey_parser::load_scene(&path, &defines).map_err(|e| e.to_string())?;
            let hash = torrey_parts::scene_hash(&desc, &defines)?;
            Ok::<_, String>((desc, hash))
        })
        .map_err(scene_error)?;
    Ok(Scene {
        desc: Arc::new(desc),
        defines,
        hash,
        built: Mutex::new(None),
    })
}

/// A render part: mean and variance of the mean over a crop window and a sample range, with the
/// metadata that identifies it.
#[pyclass(frozen, module = "torrey._native", name = "Part")]
struct PyPart(Part);

#[pymethods]
impl PyPart {
    /// (width, height) of the part's crop window.
    #[getter]
    fn shape(&self) -> (u32, u32) {
        (self.0.meta.crop.2, self.0.meta.crop.3)
    }
    /// Mean radiance, float32 RGB, row by row.
    fn mean_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        floats(py, &self.0.mean)
    }
    /// Variance of the mean, float32 RGB, row by row.
    fn variance_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        floats(py, &self.0.variance)
    }
    /// The denoised image, float32 RGB, row by row (None if the part was not denoised).
    fn denoised_bytes<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyBytes>> {
        self.0.denoised.as_ref().map(|d| floats(py, d))
    }
    /// Samples per pixel (adaptive sampling and time limits give each pixel its own), uint32.
    fn count_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let bytes: Vec<u8> = self.0.count.iter().flat_map(|c| c.to_ne_bytes()).collect();
        PyBytes::new(py, &bytes)
    }
    /// The names of the other values the samples wrote: Mitsuba's AOVs (`dd.y.T`, `nn.X`, ...),
    /// the wrapped integrator's image, the denoiser's guides (`albedo.R`, `normal.X`, ...).
    #[getter]
    fn channels(&self) -> Vec<String> {
        self.0.channels.clone()
    }
    /// One channel's per-pixel values, float32, row by row.
    fn channel_bytes<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyBytes>> {
        let values = self.0.channel_values(&[name]).ok_or_else(|| {
            PyValueError::new_err(format!(
                "no channel '{name}' (channels: {:?})",
                self.0.channels
            ))
        })?;
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_ne_bytes()).collect();
        Ok(PyBytes::new(py, &bytes))
    }
    /// A copy denoised with Intel Open Image Denoise (the part must carry the guides: render it
    /// with `denoise=True`), the guides treated as `prefilter` says ("accurate" or "fast");
    /// errors if this build has no OIDN.
    #[pyo3(signature = (prefilter = "accurate"))]
    fn denoised(&self, py: Python<'_>, prefilter: &str) -> PyResult<Self> {
        let prefilter = prefilter.parse().map_err(PyValueError::new_err)?;
        let mut part = self.0.clone();
        py.detach(|| torrey_parts::denoise_part(&mut part, prefilter))
            .map_err(PyRuntimeError::new_err)?;
        Ok(PyPart(part))
    }
    /// The metadata: scene, scene_hash, settings, width, height, spp, sample_range, crop,
    /// nonfinite_samples, clamped_pixels.
    #[getter]
    fn meta<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.0.meta;
        let d = PyDict::new(py);
        d.set_item("scene", &m.scene)?;
        d.set_item("scene_hash", &m.scene_hash)?;
        d.set_item("settings", &m.settings)?;
        d.set_item("width", m.width)?;
        d.set_item("height", m.height)?;
        d.set_item("spp", m.spp)?;
        d.set_item("sample_range", m.samples)?;
        d.set_item("crop", m.crop)?;
        d.set_item("nonfinite_samples", m.nonfinite)?;
        d.set_item("clamped_pixels", m.clamped)?;
        Ok(d)
    }
    /// The part as an EXR file in memory (what `write` writes).
    fn to_exr_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let bytes = torrey_parts::write_part_bytes(&self.0).map_err(PyRuntimeError::new_err)?;
        Ok(PyBytes::new(py, &bytes))
    }
    /// Reads a part from EXR bytes; `name` labels errors.
    #[staticmethod]
    #[pyo3(signature = (data, name = "part"))]
    fn from_exr_bytes(data: &[u8], name: &str) -> PyResult<Self> {
        torrey_parts::read_part_bytes(data, name)
            .map(PyPart)
            .map_err(PyValueError::new_err)
    }
    /// Reads a part EXR file.
    #[staticmethod]
    fn read(path: PathBuf) -> PyResult<Self> {
        torrey_parts::read_part(&path)
            .map(PyPart)
            .map_err(PyValueError::new_err)
    }
    /// Writes the part's EXR (with its metadata) and a PNG beside it; returns the PNG's path.
    fn write(&self, py: Python<'_>, path: PathBuf) -> PyResult<String> {
        py.detach(|| {
            torrey_parts::write_part(&path, &self.0)?;
            let png = path.with_extension("png");
            torrey_texture::write_png_srgb(&png, &self.0.image()).map_err(|e| e.to_string())?;
            Ok::<_, String>(png.display().to_string())
        })
        .map_err(PyRuntimeError::new_err)
    }
}

fn floats<'py>(py: Python<'py>, data: &[glam::Vec3]) -> Bound<'py, PyBytes> {
    let mut bytes = Vec::with_capacity(data.len() * 12);
    for p in data {
        for c in p.to_array() {
            bytes.extend_from_slice(&c.to_ne_bytes());
        }
    }
    PyBytes::new(py, &bytes)
}

/// Merges parts (crops and sample ranges of one render); `names` label errors.
#[pyfunction]
fn merge(py: Python<'_>, parts: Vec<Py<PyPart>>, names: Vec<String>) -> PyResult<PyPart> {
    if names.len() != parts.len() {
        return Err(PyValueError::new_err("one name per part"));
    }
    let named: Vec<(String, Part)> = names
        .into_iter()
        .zip(&parts)
        .map(|(n, p)| (n, p.get().0.clone()))
        .collect();
    py.detach(|| torrey_parts::merge(&named))
        .map(PyPart)
        .map_err(PyValueError::new_err)
}

/// Renders a slice of the scene with the command line's settings; `None` takes the scene's
/// value. `progress(done, total)` is called with the GIL after each tile.
#[pyfunction]
#[pyo3(signature = (scene, spp, seed, size, max_depth, sample_range, crop, threads, sampler, progress, label, denoise = false, noise_threshold = None, time_limit = None, denoise_prefilter = "accurate"))]
#[allow(clippy::too_many_arguments)]
fn render(
    py: Python<'_>,
    scene: &Scene,
    spp: Option<u32>,
    seed: Option<u64>,
    size: Option<(u32, u32)>,
    max_depth: Option<i32>,
    sample_range: Option<(u32, u32)>,
    crop: Option<(u32, u32, u32, u32)>,
    threads: Option<usize>,
    sampler: &str,
    progress: Option<Py<PyAny>>,
    label: Option<String>,
    denoise: bool,
    noise_threshold: Option<f32>,
    time_limit: Option<f64>,
    denoise_prefilter: &str,
) -> PyResult<PyPart> {
    let prefilter: torrey_denoise::Prefilter =
        denoise_prefilter.parse().map_err(PyValueError::new_err)?;
    let desc = &scene.desc;
    if denoise && !torrey_denoise::AVAILABLE {
        return Err(PyRuntimeError::new_err(format!(
            "denoise=True: {}",
            torrey_denoise::HOW_TO_GET
        )));
    }
    if noise_threshold.is_some_and(|t| !(t > 0.0 && t.is_finite())) {
        return Err(PyValueError::new_err("noise_threshold must be positive"));
    }
    let time_limit = match time_limit {
        Some(t) if t > 0.0 && t.is_finite() => Some(std::time::Duration::from_secs_f64(t)),
        Some(_) => return Err(PyValueError::new_err("time_limit must be positive")),
        None => None,
    };
    let (width, height) = size.unwrap_or((desc.film.width, desc.film.height));
    if width == 0 || height == 0 {
        return Err(PyValueError::new_err("film size must be positive"));
    }
    let sampler = match sampler {
        "sobol" => SamplerKind::Sobol,
        "independent" => SamplerKind::Independent,
        other => {
            return Err(PyValueError::new_err(format!(
                "sampler must be 'sobol' or 'independent', not '{other}'"
            )))
        }
    };
    // The command line's settings (src/main.rs), so the same arguments give the same pixels.
    let settings = RenderSettings::new(
        desc,
        &Overrides {
            spp,
            max_depth,
            seed,
            sampler: Some(sampler),
            guides: Some(denoise),
            noise_threshold,
            time_limit,
            ..Overrides::default()
        },
    );
    // The film's crop parameters apply to the film they were written for.
    let film_crop = desc.film.crop.filter(|_| size.is_none()).map(|c| c.rect());
    let slice = RenderSlice {
        crop: crop.or(film_crop).unwrap_or((0, 0, width, height)),
        samples: sample_range.map_or(0..settings.spp, |(a, b)| a..b),
    };
    slice
        .validate(width, height, settings.spp)
        .map_err(PyValueError::new_err)?;
    let mut meta = PartMeta {
        scene: label.unwrap_or_else(|| desc.path.display().to_string()),
        scene_hash: scene.hash.clone(),
        settings: torrey_parts::settings_text(&settings),
        width,
        height,
        spp: settings.spp,
        samples: (slice.samples.start, slice.samples.end),
        crop: slice.crop,
        nonfinite: 0,
        clamped: 0,
    };
    let callback_error: Mutex<Option<PyErr>> = Mutex::new(None);
    let result = py.detach(|| {
        let render_scene = scene.render_scene((width, height)).map_err(scene_error)?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.unwrap_or(0))
            .build()
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start threads: {e}")))?;
        let report = |done: u64, total: u64| {
            if let Some(cb) = &progress {
                Python::attach(|py| {
                    if let Err(e) = cb.call1(py, (done, total)) {
                        let mut slot = callback_error.lock().unwrap_or_else(|e| e.into_inner());
                        slot.get_or_insert(e);
                    }
                });
            }
        };
        pool.install(|| torrey_renderer::render_slice(&render_scene, &settings, &slice, &report))
            .map_err(PyValueError::new_err)
    })?;
    if let Some(e) = callback_error
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
    {
        return Err(e);
    }
    meta.nonfinite = result.nonfinite_samples;
    let mut part = Part::from_output(meta, &result);
    if denoise {
        py.detach(|| torrey_parts::denoise_part(&mut part, prefilter))
            .map_err(PyRuntimeError::new_err)?;
    }
    Ok(PyPart(part))
}

/// Writes a linear float32 RGB EXR from `data` (float32, row by row, `width * height * 3`).
#[pyfunction]
fn write_exr(py: Python<'_>, path: PathBuf, data: &[u8], width: u32, height: u32) -> PyResult<()> {
    let n = width as usize * height as usize;
    if data.len() != n * 12 {
        return Err(PyValueError::new_err(format!(
            "{} bytes for a {width}x{height} RGB float32 image (expected {})",
            data.len(),
            n * 12
        )));
    }
    let pixels = data
        .chunks_exact(12)
        .map(|c| {
            let f = |i: usize| f32::from_ne_bytes(c[i..i + 4].try_into().expect("4 bytes"));
            glam::Vec3::new(f(0), f(4), f(8))
        })
        .collect();
    let image = torrey_texture::Image::new(width, height, pixels);
    py.detach(|| torrey_texture::write_exr(Path::new(&path), &image))
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// Reads an image (EXR, PNG, ...) as torrey reads textures, linear; returns (float32 RGB bytes,
/// width, height).
#[pyfunction]
fn read_image<'py>(py: Python<'py>, path: PathBuf) -> PyResult<(Bound<'py, PyBytes>, u32, u32)> {
    let loaded = py
        .detach(|| torrey_texture::load_image(&path, false))
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let image = loaded.image;
    Ok((floats(py, &image.pixels), image.width, image.height))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scene>()?;
    m.add_class::<PyPart>()?;
    m.add_function(wrap_pyfunction!(load_file, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(merge, m)?)?;
    m.add_function(wrap_pyfunction!(write_exr, m)?)?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    Ok(())
}
