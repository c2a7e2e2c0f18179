//! Ray traversal throughput: `cargo bench -p torrey-renderer --bench traversal`.
//!
//! For each project scene, traces camera rays, then from every primary hit a diffuse-like
//! secondary ray (closest hit) and a shadow ray towards a random point of the scene's hit cloud
//! (any hit), single-threaded, and prints millions of rays per second. The rays are generated
//! once and replayed, so only the BVH queries are timed (not the surface reconstruction). The
//! last three columns trace eight jittered camera rays per pixel, as a render's samples, one by
//! one and in packets of eight (`Accel::intersect_packet`; wide nodes only) and sixteen (two
//! pixels; torrey on CPUs with AVX-512).
//! `cargo bench -p torrey-renderer --bench traversal -- cbox` runs only scenes whose file name
//! contains "cbox". Each scene is measured with 4-wide and, on CPUs with AVX2, 8-wide BVH nodes
//! (and 16-wide ones on CPUs with AVX-512).
//!
//! With `--features embree` (needs Embree 3: `bash bench/embree_traversal.sh` installs Debian's
//! `libembree-dev` and runs this) the same rays also go through Embree (`traversal/embree.rs`):
//! `rtcIntersect1`/`rtcOccluded1`, and `rtcIntersect8`/`rtcIntersect16` for the packets, the
//! scene built at `TORREY_EMBREE_QUALITY` (`low`, `medium` = Embree's default, `high` = the
//! default here), `TORREY_EMBREE_CONFIG` adds to Embree's device configuration (`isa=avx2`,
//! `verbose=2`). The bench then also checks that both find the same hits.
//!
//! `TORREY_BENCH_FTZ=1` turns on flush-to-zero and denormals-are-zero for all tracers.
//!
//! Timing: per column, 15 rounds that alternate between the tracers (so a change of machine
//! load hits all of them alike); each tracer's fastest round counts. Times are the thread's CPU
//! time on Linux (wall time elsewhere). A plain `harness = false` bench: no extra dependency
//! in the test build.

#[cfg(feature = "embree")]
#[path = "traversal/embree.rs"]
mod embree;

use glam::{Vec2, Vec3A};
use std::path::Path;
use std::time::Instant;
use torrey_renderer::{offset_origin, CameraSample, Ray};
use torrey_renderer::{AccelOptions, BvhWidth, RenderScene, Simd};

/// Column titles; each tracer may leave a column out.
const COLUMNS: [&str; 6] = [
    "primary",
    "secondary",
    "shadow",
    "camera x1",
    "packets 8",
    "packets 16",
];

/// Timed rounds per column and tracer.
const ROUNDS: usize = 15;

/// One way of tracing the rays: a name and, per column, a job returning its hit count.
struct Tracer<'a> {
    name: String,
    jobs: Vec<Option<Box<dyn Fn() -> usize + 'a>>>,
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut scenes = vec![
        root.join("scenes/cbox.xml"),
        root.join("scenes/textured_mesh.xml"),
        root.join("scenes/envmap_sky.xml"),
    ];
    let living = root.join("../shared/scenes/torrey/living-room-Wig42/scene_bgonly_available.xml");
    if living.exists() {
        scenes.push(living);
    }
    // Arguments ending in `.xml` are scenes to add (a real scene, say); the others filter.
    let (extra, filters): (Vec<String>, Vec<String>) = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .partition(|a| a.ends_with(".xml"));
    if !extra.is_empty() {
        scenes = extra.iter().map(std::path::PathBuf::from).collect();
    }
    scenes.retain(|p| {
        let name = p.file_name().unwrap().to_string_lossy();
        filters.is_empty() || filters.iter().any(|f| name.contains(f.as_str()))
    });
    println!(
        "CPU: {}; torrey SIMD level: {}; one thread; load average {}",
        cpu_model(),
        Simd::detect().name(),
        load_average()
    );
    if std::env::var_os("TORREY_BENCH_FTZ").is_some() {
        flush_denormals_to_zero();
    }
    #[cfg(feature = "embree")]
    let quality = embree_quality();
    #[cfg(feature = "embree")]
    println!("Embree 3 build quality: {quality:?}");
    println!(
        "{:<34} {:>10} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "scene / tracer",
        "triangles",
        COLUMNS[0],
        COLUMNS[1],
        COLUMNS[2],
        COLUMNS[3],
        COLUMNS[4],
        COLUMNS[5]
    );
    for path in &scenes {
        let desc = torrey_parser::load_scene(path, &[]).expect("scene loads");
        let built: Vec<RenderScene> = [
            (BvhWidth::Four, 4),
            (BvhWidth::Eight, 8),
            (BvhWidth::Sixteen, 16),
        ]
        .into_iter()
        .filter_map(|(width, nodes)| {
            let scene = RenderScene::build_with(&desc, 256, 256, AccelOptions::best(width))
                .expect("scene builds");
            // The CPU may lack AVX2 (8) or AVX-512 (16).
            (scene.accel().bvh_width() == nodes).then_some(scene)
        })
        .collect();
        let name = path.file_name().unwrap().to_string_lossy();
        let (primary, secondary, shadow) = make_rays(&built[0]);
        let (origin, pixels) = camera_samples(&built[0]);
        let samples = pixels.len() * PACKET;
        let counts = [
            primary.len(),
            secondary.len(),
            shadow.len(),
            samples,
            samples,
            samples,
        ];
        let (primary, secondary, shadow, pixels) = (&primary, &secondary, &shadow, &pixels);
        #[cfg(feature = "embree")]
        let embree = embree::Embree::new(&built[0], quality);
        let torrey = built
            .iter()
            .map(|scene| torrey_tracer(scene, primary, secondary, shadow, origin, pixels));
        #[cfg(feature = "embree")]
        let torrey = torrey.chain([embree_tracer(
            &embree, primary, secondary, shadow, origin, pixels,
        )]);
        let tracers: Vec<Tracer> = torrey.collect();

        let mut best = vec![[f64::INFINITY; COLUMNS.len()]; tracers.len()];
        let mut hits = vec![[None; COLUMNS.len()]; tracers.len()];
        for column in 0..COLUMNS.len() {
            for _ in 0..ROUNDS {
                for (t, tracer) in tracers.iter().enumerate() {
                    if let Some(job) = &tracer.jobs[column] {
                        let start = Clock::now();
                        let n = std::hint::black_box(job());
                        best[t][column] = best[t][column].min(start.elapsed());
                        hits[t][column] = Some(n);
                    }
                }
            }
        }
        for (t, tracer) in tracers.iter().enumerate() {
            let cell = |c: usize| match hits[t][c] {
                Some(_) => format!("{:.1}", counts[c] as f64 / best[t][c] / 1e6),
                None => "-".to_string(),
            };
            println!(
                "{:<34} {:>10} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12}",
                format!("{name} {}", tracer.name),
                built[0].triangle_count(),
                cell(0),
                cell(1),
                cell(2),
                cell(3),
                cell(4),
                cell(5)
            );
        }
        // Hit counts: every tracer must find the same number of hits per ray set (the camera
        // columns trace the same rays).
        let sets = [
            ("primary", &[0][..]),
            ("secondary", &[1]),
            ("shadow", &[2]),
            ("camera", &[3, 4, 5]),
        ];
        let hits = &hits;
        for (set, columns) in sets {
            let found: Vec<(String, usize)> = tracers
                .iter()
                .enumerate()
                .flat_map(|(t, tracer)| {
                    columns.iter().filter_map(move |&c| {
                        hits[t][c].map(|n| (format!("{} {}", tracer.name, COLUMNS[c]), n))
                    })
                })
                .collect();
            if found.iter().all(|(_, n)| *n == found[0].1) {
                println!(
                    "  {set}: {} hits of {} rays, all agree",
                    found[0].1, counts[columns[0]]
                );
            } else {
                let list: Vec<String> = found.iter().map(|(who, n)| format!("{who} {n}")).collect();
                println!("  {set}: hit counts DIFFER: {}", list.join(", "));
            }
        }
        // Which primitive each ray hits, and where: a different primitive at the same distance
        // is a tie (an edge shared by two triangles, coplanar or duplicated faces).
        #[cfg(feature = "embree")]
        for (set, rays) in [("primary", primary), ("secondary", secondary)] {
            let (mut differ, mut farther) = (0, 0);
            for r in rays.iter() {
                let ours = built[0].accel().intersect(r).map(|h| (h.t, h.prim));
                let theirs = embree.intersect(r);
                if ours.map(|h| h.1) != theirs.map(|h| h.1) {
                    differ += 1;
                    let tie = matches!((ours, theirs), (Some(a), Some(b)) if (a.0 - b.0).abs() <= 1e-4 * a.0.max(b.0));
                    farther += !tie as usize;
                }
            }
            println!(
                "  {set}: {differ} of {} rays hit a different primitive in Embree than in torrey \
                 ({farther} of them at a different distance or hit against miss)",
                rays.len()
            );
        }
    }
    println!("load average after: {}", load_average());
}

/// torrey's queries on `scene` (its BVH width as built).
fn torrey_tracer<'a>(
    scene: &'a RenderScene,
    primary: &'a [Ray],
    secondary: &'a [Ray],
    shadow: &'a [Ray],
    origin: Vec3A,
    pixels: &'a [[Vec3A; PACKET]],
) -> Tracer<'a> {
    let accel = scene.accel();
    let closest = |rays: &'a [Ray]| -> Box<dyn Fn() -> usize + 'a> {
        Box::new(move || rays.iter().filter(|r| accel.intersect(r).is_some()).count())
    };
    let one_by_one = move |dirs: &[Vec3A; PACKET]| {
        dirs.iter()
            .filter(|&&dir| {
                let ray = Ray {
                    origin,
                    dir,
                    tmax: f32::INFINITY,
                };
                accel.intersect(&ray).is_some()
            })
            .count()
    };
    let packets: Option<Box<dyn Fn() -> usize + 'a>> =
        (accel.packet_width() >= PACKET).then(|| {
            Box::new(move || {
                pixels
                    .iter()
                    .map(|dirs| {
                        let mut hits = [None; PACKET];
                        if accel.intersect_packet(origin, dirs, &mut hits) {
                            hits.iter().flatten().count()
                        } else {
                            one_by_one(dirs)
                        }
                    })
                    .sum()
            }) as Box<dyn Fn() -> usize + 'a>
        });
    // Sixteen-ray packets (AVX-512): two pixels' rays, as Embree's `rtcIntersect16` column.
    let packets16: Option<Box<dyn Fn() -> usize + 'a>> =
        (accel.packet_width() == 2 * PACKET).then(|| {
            Box::new(move || {
                pixels
                    .chunks(2)
                    .map(|two| {
                        let mut hits = [None; 2 * PACKET];
                        if two.len() == 2 {
                            let dirs: [Vec3A; 2 * PACKET] =
                                std::array::from_fn(|i| two[i / PACKET][i % PACKET]);
                            if accel.intersect_packet(origin, &dirs, &mut hits) {
                                return hits.iter().flatten().count();
                            }
                        }
                        two.iter().map(one_by_one).sum()
                    })
                    .sum()
            }) as Box<dyn Fn() -> usize + 'a>
        });
    Tracer {
        name: format!("torrey {}-wide", accel.bvh_width()),
        jobs: vec![
            Some(closest(primary)),
            Some(closest(secondary)),
            Some(Box::new(move || {
                shadow
                    .iter()
                    .filter(|r| !scene.visible(r.origin, r.dir, r.tmax))
                    .count()
            })),
            Some(Box::new(move || pixels.iter().map(one_by_one).sum())),
            packets,
            packets16,
        ],
    }
}

/// Embree's queries on the same primitives.
#[cfg(feature = "embree")]
fn embree_tracer<'a>(
    embree: &'a embree::Embree,
    primary: &'a [Ray],
    secondary: &'a [Ray],
    shadow: &'a [Ray],
    origin: Vec3A,
    pixels: &'a [[Vec3A; PACKET]],
) -> Tracer<'a> {
    let closest = |rays: &'a [Ray]| -> Box<dyn Fn() -> usize + 'a> {
        Box::new(move || {
            rays.iter()
                .filter(|r| embree.intersect(r).is_some())
                .count()
        })
    };
    Tracer {
        name: "embree".to_string(),
        jobs: vec![
            Some(closest(primary)),
            Some(closest(secondary)),
            Some(Box::new(move || {
                shadow.iter().filter(|r| embree.occluded(r)).count()
            })),
            Some(Box::new(move || {
                pixels
                    .iter()
                    .flatten()
                    .filter(|&&dir| {
                        let ray = Ray {
                            origin,
                            dir,
                            tmax: f32::INFINITY,
                        };
                        embree.intersect(&ray).is_some()
                    })
                    .count()
            })),
            Some(Box::new(move || {
                pixels
                    .iter()
                    .map(|dirs| embree.intersect8(origin, dirs))
                    .sum()
            })),
            Some(Box::new(move || {
                let pairs = pixels.chunks_exact(2);
                let rest: usize = pairs
                    .remainder()
                    .iter()
                    .map(|dirs| embree.intersect8(origin, dirs))
                    .sum();
                rest + pairs
                    .map(|two| {
                        let dirs: [Vec3A; 2 * PACKET] =
                            std::array::from_fn(|i| two[i / PACKET][i % PACKET]);
                        embree.intersect16(origin, &dirs)
                    })
                    .sum::<usize>()
            })),
        ],
    }
}

/// `TORREY_EMBREE_QUALITY`: `low`, `medium` or `high` (the default).
#[cfg(feature = "embree")]
fn embree_quality() -> embree::Quality {
    match std::env::var("TORREY_EMBREE_QUALITY").as_deref() {
        Ok("low") => embree::Quality::Low,
        Ok("medium") => embree::Quality::Medium,
        Ok("high") | Err(_) => embree::Quality::High,
        Ok(other) => panic!("TORREY_EMBREE_QUALITY={other}: expected low, medium or high"),
    }
}

/// `TORREY_BENCH_FTZ`: flush-to-zero and denormals-are-zero for every tracer of this thread, as
/// Embree recommends (its verbose output warns when they are off; torrey's renders leave them off).
fn flush_denormals_to_zero() {
    #[cfg(target_arch = "x86_64")]
    {
        let mut csr = 0u32;
        // SAFETY: reads and writes MXCSR through a valid local; FTZ (bit 15) and DAZ (bit 6)
        // only change how subnormal floats are treated.
        unsafe {
            std::arch::asm!("stmxcsr [{}]", in(reg) &mut csr, options(nostack));
            csr |= 0x8040;
            std::arch::asm!("ldmxcsr [{}]", in(reg) &csr, options(nostack));
        }
        println!("MXCSR: flush-to-zero and denormals-are-zero on");
    }
}

/// The first `model name` of /proc/cpuinfo ("unknown" elsewhere).
fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".to_string())
}

/// The 1, 5 and 15 minute load averages ("?" where /proc/loadavg is missing).
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".to_string())
}

/// The calling thread's CPU time on Linux (other threads' work and time spent descheduled do
/// not count), wall time elsewhere.
enum Clock {
    #[cfg(all(target_os = "linux", target_pointer_width = "64"))]
    Cpu(f64),
    #[cfg_attr(
        all(target_os = "linux", target_pointer_width = "64"),
        allow(dead_code)
    )]
    Wall(Instant),
}

impl Clock {
    fn now() -> Self {
        #[cfg(all(target_os = "linux", target_pointer_width = "64"))]
        {
            Clock::Cpu(thread_cpu_seconds())
        }
        #[cfg(not(all(target_os = "linux", target_pointer_width = "64")))]
        {
            Clock::Wall(Instant::now())
        }
    }

    /// Seconds since `now`.
    fn elapsed(&self) -> f64 {
        match self {
            #[cfg(all(target_os = "linux", target_pointer_width = "64"))]
            Clock::Cpu(start) => thread_cpu_seconds() - start,
            Clock::Wall(start) => start.elapsed().as_secs_f64(),
        }
    }
}

#[cfg(all(target_os = "linux", target_pointer_width = "64"))]
fn thread_cpu_seconds() -> f64 {
    #[repr(C)]
    struct Timespec {
        sec: i64,
        nsec: i64,
    }
    extern "C" {
        fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
    }
    const CLOCK_THREAD_CPUTIME_ID: i32 = 3;
    let mut ts = Timespec { sec: 0, nsec: 0 };
    // SAFETY: clock_gettime writes one timespec (64-bit time_t and long on 64-bit Linux).
    let ok = unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0;
    assert!(ok, "clock_gettime");
    ts.sec as f64 + ts.nsec as f64 * 1e-9
}

/// Primary rays through every pixel, and from each primary hit one random hemisphere ray and one
/// shadow segment to another primary hit point.
fn make_rays(scene: &RenderScene) -> (Vec<Ray>, Vec<Ray>, Vec<Ray>) {
    let (w, h) = (scene.camera().width(), scene.camera().height());
    let mut rnd = uniform(0x2545_f491_4f6c_dd1du64);
    let mut primary = Vec::new();
    let mut hits = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (origin, dir) = scene.camera().generate_ray(&CameraSample {
                film: Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
                lens: Vec2::ZERO,
            });
            let ray = Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            };
            primary.push(ray);
            if let Some(hit) = scene.intersect(&ray) {
                let n = if hit.ng.dot(dir) < 0.0 {
                    hit.ng
                } else {
                    -hit.ng
                };
                hits.push((hit.p, n));
            }
        }
    }
    let mut secondary = Vec::new();
    let mut shadow = Vec::new();
    for i in 0..hits.len() {
        let (p, n) = hits[i];
        let d = loop {
            let v = Vec3A::new(rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0);
            if v.length_squared() <= 1.0 && v.length_squared() > 1e-4 {
                break (v.normalize() + n).normalize_or(n);
            }
        };
        secondary.push(Ray {
            origin: offset_origin(p, n, d),
            dir: d,
            tmax: f32::INFINITY,
        });
        let (q, _) = hits[(rnd() * hits.len() as f32) as usize % hits.len()];
        let to = q - p;
        let dist = to.length();
        if dist > 1e-3 {
            let d = to / dist;
            shadow.push(Ray {
                origin: offset_origin(p, n, d),
                dir: d,
                tmax: dist * (1.0 - 2e-4),
            });
        }
    }
    (primary, secondary, shadow)
}

/// Eight camera rays through random points of every pixel: the camera's origin and each
/// pixel's directions.
fn camera_samples(scene: &RenderScene) -> (Vec3A, Vec<[Vec3A; PACKET]>) {
    let (w, h) = (scene.camera().width(), scene.camera().height());
    let mut rnd = uniform(0x9e37_79b9_7f4a_7c15u64);
    let mut origin = Vec3A::ZERO;
    let mut pixels = Vec::new();
    for y in 0..h {
        for x in 0..w {
            pixels.push(std::array::from_fn(|_| {
                let film = Vec2::new(x as f32 + rnd(), y as f32 + rnd());
                let (o, d) = scene.camera().generate_ray(&CameraSample {
                    film,
                    lens: Vec2::ZERO,
                });
                origin = o;
                d
            }));
        }
    }
    (origin, pixels)
}

/// Camera rays per packet (the eight-wide AVX2 layout's).
const PACKET: usize = 8;

/// Uniform numbers in [0, 1) from a xorshift generator started at `state`.
fn uniform(mut state: u64) -> impl FnMut() -> f32 {
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    }
}
