//! `torrey`: render a Mitsuba-style XML scene to a linear EXR and a tonemapped PNG.

mod compare;
mod limits;
mod merge;
mod output;
mod slicing;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(
    name = "torrey",
    version,
    about = "A small physically based renderer for Mitsuba-style XML scenes"
)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    render: RenderArgs,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Compare two images: RMSE, relative MSE, mean ratios; optional heatmap and side-by-side.
    Compare(compare::CompareArgs),
    /// Merge render parts (crops and sample ranges of one render) into one EXR and PNG.
    Merge(merge::MergeArgs),
}

#[derive(clap::Args, Debug)]
struct RenderArgs {
    /// The scene file (Mitsuba-style XML).
    #[arg(required = true)]
    scene: Option<PathBuf>,
    /// Output EXR; a PNG is written beside it. Default: the film's filename or <scene stem>.exr.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Samples per pixel (default: the scene's sampleCount).
    #[arg(long)]
    spp: Option<u32>,
    /// Film size as WIDTHxHEIGHT (the camera and its field of view are kept).
    #[arg(long, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Maximum path depth in Mitsuba's convention (1 = emitters only, 2 = direct light, -1 = unbounded).
    #[arg(long, allow_negative_numbers = true)]
    max_depth: Option<i32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Random seed (default: the scene's sampler seed).
    #[arg(long)]
    seed: Option<u64>,
    /// Set a scene <default> parameter, as Mitsuba's -D: -D spp=16.
    #[arg(short = 'D', value_parser = parse_define)]
    define: Vec<(String, String)>,
    /// Sample generator: `sobol` (shuffled Owen-scrambled Sobol, the default) or `independent`
    /// (uniform random numbers, like Mitsuba's independent sampler).
    #[arg(long, value_enum, default_value_t = SamplerArg::Sobol)]
    sampler: SamplerArg,
    /// Look textures up at full resolution (bilinear, as Mitsuba) instead of ray-cone mip-mapping.
    #[arg(long)]
    no_mipmap: bool,
    /// Read the scene with the torrey course's rules or Mitsuba's, instead of the detected ones
    /// (version 2.0+ is Mitsuba; 0.5/0.6 files are torrey only with a <background> or the
    /// course's bsdfs).
    #[arg(long, value_enum)]
    dialect: Option<DialectArg>,
    /// Do not draw a progress bar.
    #[arg(long)]
    quiet: bool,
    /// Change a safety cap, NAME=VALUE (repeatable): film_pixels, image_pixels, mesh_triangles,
    /// mesh_vertices, scene_bytes, volume_values, nesting_depth, threads. See
    /// docs/robustness.md.
    #[arg(long = "limit", value_parser = limits::parse_limit)]
    limits: Vec<(String, u64)>,
    /// BVH node width: `auto` (8 with AVX2 and FMA, 16 with AVX-512 from 10k primitives, else
    /// 4), `4`, `8` (needs AVX2 and FMA, else 4 is used) or `16` (needs AVX-512, else the widest
    /// available). All find the same hits; this is for comparing their speed.
    #[arg(long, value_enum, default_value_t = BvhWidthArg::Auto)]
    bvh_width: BvhWidthArg,
    /// Trace every camera ray alone instead of each pixel's in packets of eight (packets need
    /// 8-wide nodes). The same hits; this is for comparing their speed.
    #[arg(long)]
    no_packets: bool,
    /// How the path tracer runs: `scalar` (one path to its end after another), `wavefront` (a
    /// pixel's samples advanced a bounce at a time, in batches) or `auto` (the wavefront for
    /// scenes with an environment map, or whose diffuse surfaces and lights it shades in SIMD
    /// lanes with AVX2 or AVX-512, where it is faster). The same images, bit for bit.
    #[arg(long, value_enum, default_value_t = PathLoopArg::Auto)]
    integrator_loop: PathLoopArg,
    /// Render only this film window, X,Y,WIDTH,HEIGHT in pixels of the full film (a part for
    /// `torrey merge`; the EXR records the crop).
    #[arg(long, value_parser = slicing::parse_crop)]
    crop: Option<(u32, u32, u32, u32)>,
    /// Render only samples FIRST..END-1 of every pixel, by their global index (a part for
    /// `torrey merge`; the EXR records the range).
    #[arg(long, value_parser = slicing::parse_sample_range)]
    sample_range: Option<(u32, u32)>,
    /// Denoise with Intel Open Image Denoise (albedo and normal guides from the first non-delta
    /// hit): the EXR's RGB and the PNG are the denoised image; the noisy image (noisy.R/G/B),
    /// albedo.R/G/B and normal.X/Y/Z stay in the EXR.
    #[arg(long)]
    denoise: bool,
    /// With --denoise, how the noisy guides are treated (Cycles' names): `accurate` denoises
    /// each guide first (OIDN's recommended setting: 4-27% lower error at 16 spp, about four
    /// times the denoiser's time), `fast` denoises them together with the image.
    #[arg(long, value_name = "accurate|fast", default_value = "accurate")]
    denoise_prefilter: torrey_denoise::Prefilter,
    /// Adaptive sampling: each pixel stops once its relative standard error is predicted under
    /// T (judged from a uniform pilot of its neighbours); --spp is the cap. The EXR's `count`
    /// channel holds each pixel's samples.
    #[arg(long, value_name = "T", value_parser = parse_positive)]
    noise_threshold: Option<f32>,
    /// Render in passes until SECONDS have gone, stopping at a pass boundary (--spp, or the
    /// scene's, is the cap); with --noise-threshold the time left goes to the noisiest pixels.
    #[arg(long, value_name = "SECONDS", value_parser = parse_positive)]
    time_limit: Option<f32>,
}

fn parse_positive(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("expected a positive number, got '{s}'")),
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum BvhWidthArg {
    Auto,
    #[value(name = "4")]
    Four,
    #[value(name = "8")]
    Eight,
    #[value(name = "16")]
    Sixteen,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum DialectArg {
    Torrey,
    Mitsuba,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum PathLoopArg {
    Auto,
    Scalar,
    Wavefront,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum SamplerArg {
    Sobol,
    Independent,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, got '{s}'"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in '{s}'"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in '{s}'"))?;
    if w == 0 || h == 0 {
        return Err(format!("film size must be positive, got '{s}'"));
    }
    Ok((w, h))
}

fn parse_define(s: &str) -> Result<(String, String), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("expected name=value, got '{s}'"))?;
    Ok((k.trim().to_string(), v.trim().to_string()))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Some(Command::Compare(args)) => compare::run(args),
        Some(Command::Merge(args)) => merge::run(args),
        None => render_command(&cli.render),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("{message}");
            ExitCode::FAILURE
        }
    }
}

fn render_command(args: &RenderArgs) -> Result<(), String> {
    let scene_path = args.scene.as_ref().ok_or("no scene file given")?;
    if args.denoise && !torrey_denoise::AVAILABLE {
        return Err(format!("--denoise: {}", torrey_denoise::HOW_TO_GET));
    }
    let limits = limits::Limits::from_args(&args.limits)?;
    torrey_texture::set_image_pixel_limit(limits.image_pixels);
    if let Some((w, h)) = args.size {
        if w as u64 * h as u64 > limits.parser.film_pixels {
            return Err(format!(
                "--size {w}x{h} is {} pixels, more than the limit of {} (raise with --limit film_pixels=N)",
                w as u64 * h as u64,
                limits.parser.film_pixels
            ));
        }
    }
    if let Some(t) = args.threads {
        if t as u64 > limits.threads {
            return Err(format!(
                "--threads {t} is more than the limit of {} (raise with --limit threads=N)",
                limits.threads
            ));
        }
    }
    // One pool of `--threads` workers for loading, building and rendering.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .map_err(|e| format!("cannot start worker threads: {e}"))?;
    let load_start = Instant::now();
    let options = torrey_parser::LoadOptions {
        overrides: args.define.clone(),
        dialect: args.dialect.map(|d| match d {
            DialectArg::Torrey => torrey_parser::Dialect::Torrey,
            DialectArg::Mitsuba => torrey_parser::Dialect::Mitsuba3,
        }),
        limits: limits.parser.clone(),
    };
    let scene = pool
        .install(|| torrey_parser::load_scene_with(scene_path, &options))
        .map_err(|e| e.to_string())?;
    for w in &scene.warnings {
        eprintln!("{w}");
    }
    let parse_time = load_start.elapsed();
    let (width, height) = args.size.unwrap_or((scene.film.width, scene.film.height));
    let settings = torrey_renderer::RenderSettings::new(
        &scene,
        &torrey_renderer::Overrides {
            spp: args.spp,
            max_depth: args.max_depth,
            seed: args.seed,
            sampler: Some(match args.sampler {
                SamplerArg::Sobol => torrey_renderer::SamplerKind::Sobol,
                SamplerArg::Independent => torrey_renderer::SamplerKind::Independent,
            }),
            mipmapping: Some(!args.no_mipmap),
            packets: Some(!args.no_packets),
            path_loop: Some(match args.integrator_loop {
                PathLoopArg::Auto => torrey_renderer::PathLoop::Auto,
                PathLoopArg::Scalar => torrey_renderer::PathLoop::Scalar,
                PathLoopArg::Wavefront => torrey_renderer::PathLoop::Wavefront,
            }),
            tile_size: None,
            guides: Some(args.denoise),
            noise_threshold: args.noise_threshold,
            time_limit: args.time_limit.map(std::time::Duration::from_secs_f32),
        },
    );
    let build_start = Instant::now();
    // The whole render's samples (not a part's: every part must trace the same BVH).
    let accel = torrey_renderer::AccelOptions {
        width: match args.bvh_width {
            BvhWidthArg::Auto => torrey_renderer::BvhWidth::Auto,
            BvhWidthArg::Four => torrey_renderer::BvhWidth::Four,
            BvhWidthArg::Eight => torrey_renderer::BvhWidth::Eight,
            BvhWidthArg::Sixteen => torrey_renderer::BvhWidth::Sixteen,
        },
        samples: u64::from(width) * u64::from(height) * u64::from(settings.spp),
    };
    // The scene's content hash (for the part's metadata: every file it names read again)
    // beside the build.
    let (render_scene, scene_hash) = pool.install(|| {
        rayon::join(
            || torrey_renderer::RenderScene::build_with(&scene, width, height, accel),
            || torrey_parts::scene_hash(&scene, &args.define),
        )
    });
    let render_scene = render_scene.map_err(|e| e.to_string())?;
    let scene_hash = scene_hash?;
    for w in &render_scene.warnings {
        eprintln!("warning: {w}");
    }
    let build_time = build_start.elapsed();
    let output = output_path(
        args.output.as_deref(),
        scene_path,
        scene.film.filename.as_deref(),
    );

    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        let bar = ProgressBar::new(1);
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {wide_bar} {percent}% eta {eta} {msg}",
            )
            .expect("valid progress template"),
        );
        bar
    };
    let progress = |done: u64, total: u64| {
        bar.set_length(total);
        bar.set_position(done);
    };
    let report = |r: &torrey_renderer::PassReport| bar.set_message(pass_message(r));
    let slice = torrey_renderer::RenderSlice {
        crop: slicing::default_crop(args.crop, &scene.film, args.size),
        samples: args.sample_range.map_or(0..settings.spp, |(a, b)| a..b),
    };
    slice.validate(width, height, settings.spp)?;
    let meta = slicing::part_meta(&scene, scene_hash, &settings, (width, height), &slice)?;
    let cpu_before = process_cpu_seconds();
    let out = pool.install(|| {
        torrey_renderer::render_slice_reporting(
            &render_scene,
            &settings,
            &slice,
            &progress,
            &report,
        )
    })?;
    let render_cpu = process_cpu_seconds().zip(cpu_before).map(|(a, b)| a - b);
    bar.finish_and_clear();

    let mut part = torrey_parts::Part::from_output(meta, &out);
    if args.denoise {
        let seconds =
            pool.install(|| torrey_parts::denoise_part(&mut part, args.denoise_prefilter))?;
        eprintln!("denoised in {seconds:.2} s");
    }
    let write_start = Instant::now();
    let png = pool.install(|| slicing::write_outputs(&output, &part))?;
    let write_time = write_start.elapsed();

    // Samples that counted (adaptive sampling and time limits give pixels their own counts).
    let samples: u64 = out.counts.iter().map(|&c| c as u64).sum();
    let secs = out.elapsed.as_secs_f64();
    eprintln!(
        "{}: {} dialect ({}); {}x{} px, {} spp, max depth {}, {} triangles{}; load {:.2} s, build {:.2} s, render {:.2} s, {:.2} M samples/s, {:.2} M rays/s ({} closest + {} shadow), first tile after {:.3} s, {}-wide BVH, SIMD {}{}, write {:.2} s",
        scene_path.display(),
        scene.dialect,
        scene.dialect_reason,
        out.image.width,
        out.image.height,
        out.spp,
        settings.integrator.max_depth(),
        render_scene.triangle_count(),
        match render_scene.instance_count() {
            0 => String::new(),
            n => format!(" stored, {n} instances"),
        },
        parse_time.as_secs_f64(),
        build_time.as_secs_f64(),
        secs,
        samples as f64 / secs.max(1e-9) / 1e6,
        (out.rays.closest + out.rays.shadow) as f64 / secs.max(1e-9) / 1e6,
        out.rays.closest,
        out.rays.shadow,
        out.first_tile.as_secs_f64(),
        render_scene.accel().bvh_width(),
        torrey_renderer::Simd::detect().name(),
        render_cpu.map_or(String::new(), |s| format!(", render CPU {s:.2} s")),
        write_time.as_secs_f64(),
    );
    if out.passes > 1 || settings.noise_threshold.is_some() {
        eprintln!(
            "{}",
            passes_summary(&out, settings.noise_threshold, settings.spp)
        );
    }
    if out.nonfinite_samples > 0 {
        eprintln!(
            "warning: {} samples were NaN or infinite and were dropped",
            out.nonfinite_samples
        );
    }
    if out.clamped_pixels > 0 {
        eprintln!("{}", clamped_warning(out.clamped_pixels));
    }
    eprintln!("wrote {} and {}", output.display(), png.display());
    Ok(())
}

/// The warning for pixels whose mean or variance did not fit in a 32-bit float.
pub(crate) fn clamped_warning(pixels: u64) -> String {
    format!(
        "warning: {pixels} pixels had a mean or variance beyond the largest 32-bit float \
         (3.4e38) and were clamped to it"
    )
}

/// The progress bar's message after a pass: samples per pixel so far, the noise estimate and
/// the time left.
fn pass_message(r: &torrey_renderer::PassReport) -> String {
    let mut m = format!(
        "pass {}: {:.1} spp, median error {:.3}",
        r.pass,
        r.samples as f64 / r.pixels.max(1) as f64,
        r.median_error
    );
    if let Some(u) = r.under_threshold {
        m += &format!(", {:.0}% under the threshold", u * 100.0);
    }
    if let Some(t) = r.time_left {
        m += &format!(", {:.1} s left", t.as_secs_f64());
    }
    m
}

/// One line on a render in passes: passes, samples per pixel (mean and range) and, with a noise
/// threshold, the share of pixels under it and of those the cap `spp` held over it (the cap is
/// a hard limit: a threshold it prevents is not met, and the line says so).
fn passes_summary(out: &torrey_renderer::RenderOutput, threshold: Option<f32>, spp: u32) -> String {
    let n = out.counts.len().max(1);
    let total: u64 = out.counts.iter().map(|&c| c as u64).sum();
    let (lo, hi) = out
        .counts
        .iter()
        .fold((u32::MAX, 0), |(a, b), &c| (a.min(c), b.max(c)));
    let mut line = format!(
        "{} passes, {:.1} spp on average ({lo} to {hi})",
        out.passes,
        total as f64 / n as f64
    );
    if let Some(t) = threshold {
        let (mut under, mut capped) = (0, 0);
        for i in 0..out.counts.len() {
            if torrey_renderer::relative_error(out.image.pixels[i], out.variance.pixels[i]) < t {
                under += 1;
            } else if out.counts[i] >= spp {
                capped += 1;
            }
        }
        line += &format!(
            ", {:.1}% of pixels under the threshold {t}",
            100.0 * under as f64 / n as f64
        );
        if capped > 0 {
            line += &format!(
                " ({:.1}% over it at the --spp cap {spp}: a higher cap lets them reach it)",
                100.0 * capped as f64 / n as f64
            );
        }
    }
    line
}

/// The output EXR: `-o`, else the film's filename (with .exr), else `<scene stem>.exr`, in the
/// current directory. Only the film filename's last component is used: a scene file must not
/// choose where on the disk torrey writes.
fn output_path(explicit: Option<&Path>, scene: &Path, film_name: Option<&str>) -> PathBuf {
    if let Some(p) = explicit {
        return p.to_path_buf();
    }
    if let Some(name) = film_name.and_then(|n| Path::new(n).file_name()) {
        return PathBuf::from(name).with_extension("exr");
    }
    let stem = scene
        .file_stem()
        .map_or("render".into(), |s| s.to_string_lossy().into_owned());
    PathBuf::from(format!("{stem}.exr"))
}

/// CPU seconds (user + system, all threads) this process has used, from `/proc/self/stat`
/// (Linux; None elsewhere). Benchmarks compare it between renderers because, unlike wall time,
/// it hardly depends on other load on the machine.
fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let mut fields = rest.split_whitespace().skip(11);
    let utime: u64 = fields.next()?.parse().ok()?;
    let stime: u64 = fields.next()?.parse().ok()?;
    // Clock ticks; USER_HZ is 100 on every Linux architecture's user-space ABI.
    Some((utime + stime) as f64 / 100.0)
}
