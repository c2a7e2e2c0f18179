//! `torrey-fuzz`: mutation fuzzing of torrey's input paths on stable Rust (no cargo-fuzz, no
//! nightly). Each target starts from the project's own files (scenes/*.xml, scenes/meshes,
//! textures/, plus small generated PLY, serialized, JPEG, BMP, TGA and HDR files), mutates them
//! (bit flips, interesting integers, byte and line duplication, deletion, splicing, and
//! replacing number tokens with NaN, inf, 1e39, 4294967296, ...) and feeds them to:
//!
//! - `xml`: the scene parser (`parse_scene_str`), meshes and textures resolved beside the scenes;
//! - `mesh`: the OBJ, PLY and serialized loaders, through a one-shape scene;
//! - `image`: the image decoders (`load_image`);
//! - `render`: parse, build (BVH, textures, lights) and render 8x8 pixels at 1 spp.
//!
//! There is no coverage instrumentation; as a cheap stand-in, an input whose outcome (the error
//! message with digits removed, or success) was not seen before joins the corpus. A panic is
//! caught, its input saved as `OUT/TARGET/panic-N.EXT` and the run exits with status 1. Before
//! each run the input is written to `OUT/TARGET/current.EXT`, so a crash that kills the process
//! (SIGSEGV, allocation abort) leaves it behind; an input running longer than `--timeout` is
//! saved as `hang.EXT` and the run exits with status 3. Run under `ulimit -v` to turn runaway
//! allocations into crashes (`.ci/fuzz.sh` does).
//!
//! ```sh
//! cargo run --profile ci -p torrey-fuzz -- xml --seconds 1800
//! ```

mod mutate;
mod rng;
mod seeds;
mod target;

use mutate::mutate_once;
use rng::Rng;
use seeds::{project_root, seeds, Input};
use std::collections::HashSet;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};
use target::{signature, Harness, Target};

/// Command-line arguments.
struct Args {
    target: Target,
    seconds: f64,
    seed: u64,
    out: PathBuf,
    timeout: f64,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let target = match args.next().as_deref() {
        Some("xml") => Target::Xml,
        Some("mesh") => Target::Mesh,
        Some("image") => Target::Image,
        Some("render") => Target::Render,
        other => {
            return Err(format!(
                "usage: torrey-fuzz xml|mesh|image|render [--seconds S] [--seed N] [--out DIR] [--timeout S] (got {other:?})"
            ))
        }
    };
    let mut a = Args {
        target,
        seconds: 30.0,
        seed: 0x5EED,
        out: project_root().join("target/fuzz"),
        timeout: 10.0,
    };
    while let Some(flag) = args.next() {
        let value = args.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let num = || {
            value
                .parse::<f64>()
                .map_err(|_| format!("bad value for {flag}: {value}"))
        };
        match flag.as_str() {
            "--seconds" => a.seconds = num()?,
            "--seed" => a.seed = num()? as u64,
            "--out" => a.out = PathBuf::from(&value),
            "--timeout" => a.timeout = num()?,
            _ => return Err(format!("unknown flag {flag}")),
        }
    }
    Ok(a)
}

/// Milliseconds since start at which the current input began; 0 when idle.
static CURRENT_SINCE: AtomicU64 = AtomicU64::new(0);

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let dir = args.out.join(args.target.name());
    std::fs::create_dir_all(&dir).expect("create the output folder");
    let mut corpus = seeds(args.target);
    if corpus.is_empty() {
        eprintln!("no seed files found under {}", project_root().display());
        std::process::exit(2);
    }
    // Keep the library's own panic message off the terminal: we report panics ourselves.
    std::panic::set_hook(Box::new(|info| {
        let msg = info.to_string();
        if let Ok(mut m) = PANIC_MESSAGE.lock() {
            *m = msg;
        }
    }));
    torrey_texture::set_image_pixel_limit(1 << 22);
    let limits = torrey_parser::Limits {
        mesh_triangles: 1 << 21,
        mesh_vertices: 1 << 21,
        ..Default::default()
    };
    let harness = Harness {
        target: args.target,
        dir: dir.clone(),
        scenes: project_root().join("scenes"),
        limits,
    };

    let start = Instant::now();
    let timeout_ms = (args.timeout * 1000.0) as u64;
    {
        let dir = dir.clone();
        std::thread::spawn(move || loop {
            std::thread::sleep(Duration::from_millis(100));
            let since = CURRENT_SINCE.load(Ordering::Relaxed);
            let now = start.elapsed().as_millis() as u64 + 1;
            if since != 0 && now.saturating_sub(since) > timeout_ms {
                let current = std::fs::read_dir(&dir).ok().and_then(|mut d| {
                    d.find_map(|e| {
                        let e = e.ok()?;
                        let name = e.file_name().to_string_lossy().into_owned();
                        name.starts_with("current.").then(|| e.path())
                    })
                });
                if let Some(c) = current {
                    let hang = c.with_file_name(
                        c.file_name()
                            .unwrap()
                            .to_string_lossy()
                            .replace("current", "hang"),
                    );
                    let _ = std::fs::copy(&c, &hang);
                    eprintln!(
                        "HANG: an input ran longer than {timeout_ms} ms; saved as {}",
                        hang.display()
                    );
                } else {
                    eprintln!("HANG: an input ran longer than {timeout_ms} ms");
                }
                std::process::exit(3);
            }
        });
    }

    let mut rng = Rng(args.seed | 1);
    let mut seen: HashSet<String> = HashSet::new();
    let mut execs: u64 = 0;
    let mut ok: u64 = 0;
    let deadline = Duration::from_secs_f64(args.seconds);
    let seed_count = corpus.len();
    while start.elapsed() < deadline {
        // The seeds themselves first, then mutants of random corpus entries.
        let input = if (execs as usize) < seed_count {
            corpus[execs as usize].clone()
        } else {
            let base = &corpus[rng.below(corpus.len())];
            let other = corpus[rng.below(corpus.len())].bytes.clone();
            let mut bytes = base.bytes.clone();
            let text = args.target.is_text(&base.ext);
            let stack = if rng.chance(4) {
                16
            } else if text {
                2
            } else {
                4
            };
            for _ in 0..1 + rng.below(stack) {
                mutate_once(&mut rng, &mut bytes, &other, &base.ext);
            }
            bytes.truncate(1 << 20);
            Input {
                ext: base.ext.clone(),
                bytes,
            }
        };
        let file = dir.join(format!("current.{}", input.ext));
        // Remove other extensions' current files so the watchdog finds this one.
        for e in [
            "xml",
            "obj",
            "ply",
            "serialized",
            "png",
            "jpg",
            "jpeg",
            "exr",
            "hdr",
            "bmp",
            "tga",
        ] {
            if e != input.ext {
                let _ = std::fs::remove_file(dir.join(format!("current.{e}")));
            }
        }
        std::fs::write(&file, &input.bytes).expect("write the current input");
        let variant = rng.next();
        CURRENT_SINCE.store(start.elapsed().as_millis() as u64 + 1, Ordering::Relaxed);
        let result = catch_unwind(AssertUnwindSafe(|| harness.run(&input, &file, variant)));
        CURRENT_SINCE.store(0, Ordering::Relaxed);
        execs += 1;
        let result = match result {
            Ok(r) => r,
            Err(_) => {
                let msg = PANIC_MESSAGE.lock().map(|m| m.clone()).unwrap_or_default();
                let saved = harness.dir.join(format!("panic-{execs}.{}", input.ext));
                let _ = std::fs::write(&saved, &input.bytes);
                eprintln!(
                    "PANIC in target {} after {execs} execs: {msg}\n  input saved as {}",
                    args.target.name(),
                    saved.display()
                );
                std::process::exit(1);
            }
        };
        ok += result.is_ok() as u64;
        let sig = signature(&result, &harness.dir);
        match std::env::var("TORREY_FUZZ_VERBOSE").as_deref() {
            Ok("all") => eprintln!("outcome: {sig}"),
            Ok(_) if !seen.contains(&sig) => eprintln!("new outcome: {sig}"),
            _ => {}
        }
        // New outcomes join the corpus; once it is full they replace a random non-seed entry,
        // and accepted inputs are kept preferentially (they reach the deepest code).
        let accepted = result.is_ok();
        // Malformed text rarely leads anywhere new: keep few of those.
        let malformed = sig.starts_with("malformed");
        if seen.insert(sig) && (execs as usize) >= seed_count && (!malformed || rng.chance(8)) {
            if corpus.len() < 4096 {
                corpus.push(input);
            } else {
                let victim = seed_count + rng.below(corpus.len() - seed_count);
                corpus[victim] = input;
            }
        } else if accepted && (execs as usize) >= seed_count && rng.chance(16) {
            let victim = seed_count + rng.below(corpus.len() - seed_count);
            if corpus.len() < 4096 {
                corpus.push(input);
            } else {
                corpus[victim] = input;
            }
        }
    }
    let secs = start.elapsed().as_secs_f64();
    println!(
        "{}: {execs} execs in {secs:.0} s ({:.0}/s), {ok} accepted, {} outcome classes, corpus {} (from {seed_count} seeds), no panic, crash or hang",
        args.target.name(),
        execs as f64 / secs,
        seen.len(),
        corpus.len()
    );
}

/// The last panic's message (from any thread: rayon workers re-raise on the caller).
static PANIC_MESSAGE: std::sync::Mutex<String> = std::sync::Mutex::new(String::new());
