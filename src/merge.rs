//! `torrey merge`: puts render parts (crops and sample ranges) back together.

use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// Part EXRs written by `torrey --crop ... --sample-range ...` (or the distributed renderer).
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// The merged EXR; a PNG is written beside it.
    #[arg(short, long)]
    output: PathBuf,
    /// Denoise the merged image (parts rendered with --denoise carry the guides; a denoised
    /// part's own denoised image is not merged: denoising does not commute with averaging).
    #[arg(long)]
    denoise: bool,
    /// With --denoise, how the noisy guides are treated: `accurate` (each denoised first) or
    /// `fast` (see `torrey --help`).
    #[arg(long, value_name = "accurate|fast", default_value = "accurate")]
    denoise_prefilter: torrey_denoise::Prefilter,
}

pub fn run(args: &MergeArgs) -> Result<(), String> {
    if args.denoise && !torrey_denoise::AVAILABLE {
        return Err(format!("--denoise: {}", torrey_denoise::HOW_TO_GET));
    }
    let parts = args
        .parts
        .iter()
        .map(|p| Ok((p.display().to_string(), torrey_parts::read_part(p)?)))
        .collect::<Result<Vec<_>, String>>()?;
    let mut merged = torrey_parts::merge(&parts)?;
    if args.denoise {
        let seconds = torrey_parts::denoise_part(&mut merged, args.denoise_prefilter)?;
        eprintln!("denoised in {seconds:.2} s");
    }
    let png = crate::slicing::write_outputs(&args.output, &merged)?;
    let m = &merged.meta;
    eprintln!(
        "merged {} parts of {}: {}x{} px, {} spp; wrote {} and {}",
        parts.len(),
        m.scene,
        m.crop.2,
        m.crop.3,
        m.spp,
        args.output.display(),
        png.display()
    );
    if m.nonfinite > 0 {
        eprintln!(
            "warning: {} samples were NaN or infinite and were dropped",
            m.nonfinite
        );
    }
    if m.clamped > 0 {
        eprintln!("{}", crate::clamped_warning(m.clamped));
    }
    Ok(())
}
