//! Merging parts: crops go side by side, sample ranges combine by their sample counts (by their
//! weight sums for splatted filters).

use crate::part::Part;
use glam::Vec3;
use std::collections::BTreeMap;

/// Merges named parts (`(name, part)`; names label errors) into one: the whole film, or the one
/// crop window all parts share, with all `0..spp` samples. For every crop window, its parts'
/// sample ranges must not overlap and must cover `0..spp`; the windows must not overlap and must
/// cover the film. The mean is the sample-count-weighted mean of the parts' means, and the
/// variance comes from Chan et al.'s parallel formula (M2 = M2_a + M2_b + delta^2 n_a n_b / n),
/// both in f64: the one-piece render's values to float rounding. Pixels of splatted filters
/// (a weight sum other than the count) merge by weight sums: the mean is sum(W_k m_k) / sum W_k,
/// the one-piece render's to float rounding, and the variance that of this mean,
/// sum(W_k^2 var_k) / (sum W_k)^2 (parts are independent; it differs from the one-piece
/// render's estimate only by the noise of estimating a variance).
pub fn merge(parts: &[(String, Part)]) -> Result<Part, String> {
    let Some((first_name, first)) = parts.first() else {
        return Err("no parts to merge".into());
    };
    let meta = &first.meta;
    let (fw, fh, spp) = (meta.width, meta.height, meta.spp);
    for (name, part) in parts {
        if let Some(why) = meta.mismatch(&part.meta) {
            return Err(format!("{name} does not belong with {first_name}: {why}"));
        }
        let m = &part.meta;
        let (x, y, w, h) = m.crop;
        if w == 0 || h == 0 || x as u64 + w as u64 > fw as u64 || y as u64 + h as u64 > fh as u64 {
            return Err(format!(
                "{name}: crop {x},{y},{w},{h} does not fit the {fw}x{fh} film"
            ));
        }
        if m.samples.0 >= m.samples.1 || m.samples.1 > spp {
            return Err(format!(
                "{name}: sample range {}..{} is not a part of 0..{spp}",
                m.samples.0, m.samples.1
            ));
        }
        if part.mean.len() != (w * h) as usize
            || part.variance.len() != part.mean.len()
            || part.count.len() != part.mean.len()
            || part.weight.len() != part.mean.len()
        {
            return Err(format!("{name}: pixel count does not match its crop"));
        }
    }

    // Sample ranges, per crop window.
    let mut by_crop: BTreeMap<(u32, u32, u32, u32), Vec<usize>> = BTreeMap::new();
    for (i, (_, part)) in parts.iter().enumerate() {
        by_crop.entry(part.meta.crop).or_default().push(i);
    }
    for (crop, members) in by_crop.iter_mut() {
        members.sort_by_key(|&i| parts[i].1.meta.samples);
        let (x, y, w, h) = *crop;
        let mut next = 0u32;
        let mut prev: Option<usize> = None;
        for &i in members.iter() {
            let (a, b) = parts[i].1.meta.samples;
            if a < next {
                let p = prev.expect("a range starts before 0 only after another");
                return Err(format!(
                    "{} and {} overlap: both hold samples {}..{} of crop {x},{y},{w},{h}",
                    parts[p].0,
                    parts[i].0,
                    a,
                    next.min(b)
                ));
            }
            if a > next {
                return Err(format!(
                    "missing samples {next}..{a} of crop {x},{y},{w},{h}: no part holds them"
                ));
            }
            next = b;
            prev = Some(i);
        }
        if next < spp {
            return Err(format!(
                "missing samples {next}..{spp} of crop {x},{y},{w},{h}: no part holds them"
            ));
        }
    }

    // Crop windows: one shared window, or the whole film tiled without gaps or overlaps.
    let out_crop = if by_crop.len() == 1 {
        *by_crop.keys().next().expect("one crop")
    } else {
        (0, 0, fw, fh)
    };
    let (ox, oy, ow, oh) = out_crop;
    let mut owner: Vec<u32> = vec![u32::MAX; ow as usize * oh as usize];
    for (&(x, y, w, h), members) in &by_crop {
        let rep = members[0] as u32;
        for py in y..y + h {
            for px in x..x + w {
                let o = &mut owner[((py - oy) * ow + (px - ox)) as usize];
                if *o != u32::MAX {
                    let c = parts[*o as usize].1.meta.crop;
                    return Err(format!(
                        "{} (crop {x},{y},{w},{h}) and {} (crop {},{},{},{}) overlap at pixel {px},{py}",
                        parts[rep as usize].0, parts[*o as usize].0, c.0, c.1, c.2, c.3
                    ));
                }
                *o = rep;
            }
        }
    }
    if let Some(hole) = owner.iter().position(|&o| o == u32::MAX) {
        let missing = owner.iter().filter(|&&o| o == u32::MAX).count();
        return Err(format!(
            "missing pixels: no part covers {missing} pixels of the {ow}x{oh} film, the first at {},{}",
            ox + hole as u32 % ow,
            oy + hole as u32 / ow
        ));
    }

    // The other values the samples wrote: the same channels in every part (in any order).
    let names = first.channels.clone();
    let ch = names.len();
    let mut order: Vec<Vec<usize>> = Vec::with_capacity(parts.len());
    for (name, part) in parts {
        let mut sorted = part.channels.clone();
        sorted.sort();
        let mut expected = names.clone();
        expected.sort();
        if sorted != expected {
            return Err(format!(
                "{name} does not belong with {first_name}: other channels ({} vs {})",
                part.channels.join(","),
                names.join(",")
            ));
        }
        if part.extras.len() != part.mean.len() * ch {
            return Err(format!("{name}: channel values do not match its pixels"));
        }
        order.push(
            names
                .iter()
                .map(|n| part.channels.iter().position(|c| c == n).expect("same set"))
                .collect(),
        );
    }

    let mut mean = vec![Vec3::ZERO; owner.len()];
    let mut variance = vec![Vec3::ZERO; owner.len()];
    let mut count = vec![0u32; owner.len()];
    let mut weight = vec![0f32; owner.len()];
    // Pixels whose merged mean or variance left f32's range (clamped to it, as the film does).
    let mut clamped = 0u64;
    let to_f32 = |v: [f64; 3], hit: &mut bool| {
        let limit = f32::MAX as f64;
        let c = v.map(|x| {
            if x.is_nan() {
                0.0
            } else {
                x.clamp(-limit, limit)
            }
        });
        *hit |= c != v;
        Vec3::from_array(c.map(|x| x as f32))
    };
    let mut extras = vec![0f32; owner.len() * ch];
    let mut sums = vec![0f64; ch];
    for (&(x, y, w, h), members) in &by_crop {
        for i in 0..(w * h) as usize {
            let (px, py) = (x + i as u32 % w, y + i as u32 / w);
            let o = ((py - oy) * ow + (px - ox)) as usize;
            let mut hit = false;
            let unit_weights = members.iter().all(|&k| {
                let part = &parts[k].1;
                part.weight[i] == part.count[i] as f32
            });
            // Channel values: means weighted by the parts' sample counts (weight sums).
            if ch > 0 {
                sums.iter_mut().for_each(|s| *s = 0.0);
                let mut total = 0.0f64;
                for &k in members {
                    let part = &parts[k].1;
                    let wk = if unit_weights {
                        part.count[i] as f64
                    } else {
                        part.weight[i] as f64
                    };
                    if part.count[i] == 0 || wk == 0.0 {
                        continue;
                    }
                    total += wk;
                    for (s, &c) in sums.iter_mut().zip(&order[k]) {
                        *s += wk * part.extras[i * ch + c] as f64;
                    }
                }
                if total != 0.0 {
                    for (e, s) in extras[o * ch..(o + 1) * ch].iter_mut().zip(&sums) {
                        *e = (s / total) as f32;
                    }
                }
            }
            if !unit_weights {
                let (mut n, mut wsum, mut s, mut v) = (0u64, 0.0f64, [0.0f64; 3], [0.0f64; 3]);
                for &k in members {
                    let part = &parts[k].1;
                    if part.count[i] == 0 {
                        continue;
                    }
                    let wk = part.weight[i] as f64;
                    n += part.count[i] as u64;
                    wsum += wk;
                    for c in 0..3 {
                        s[c] += wk * part.mean[i][c] as f64;
                        v[c] += wk * wk * part.variance[i][c] as f64;
                    }
                }
                if wsum != 0.0 {
                    mean[o] = to_f32(s.map(|t| t / wsum), &mut hit);
                    variance[o] = to_f32(v.map(|t| t / (wsum * wsum)), &mut hit);
                }
                clamped += hit as u64;
                count[o] = n.min(u32::MAX as u64) as u32;
                weight[o] = wsum as f32;
                continue;
            }
            let (mut n, mut m, mut m2) = (0.0f64, [0.0f64; 3], [0.0f64; 3]);
            for &k in members {
                let part = &parts[k].1;
                // Per-pixel counts: samples whose filter offset left the film do not count.
                let nb = part.count[i] as f64;
                if nb == 0.0 {
                    continue;
                }
                let total = n + nb;
                for c in 0..3 {
                    let mb = part.mean[i][c] as f64;
                    let m2b = part.variance[i][c] as f64 * nb * (nb - 1.0);
                    let delta = mb - m[c];
                    m[c] += delta * nb / total;
                    m2[c] += m2b + delta * delta * n * nb / total;
                }
                n = total;
            }
            mean[o] = to_f32(m, &mut hit);
            count[o] = n as u32;
            weight[o] = n as f32;
            variance[o] = if n > 1.0 {
                to_f32(m2.map(|v| v / (n * (n - 1.0))), &mut hit)
            } else {
                Vec3::ZERO
            };
            clamped += hit as u64;
        }
    }
    let mut out_meta = meta.clone();
    out_meta.samples = (0, spp);
    out_meta.crop = out_crop;
    out_meta.nonfinite = parts.iter().map(|(_, p)| p.meta.nonfinite).sum();
    out_meta.clamped = clamped + parts.iter().map(|(_, p)| p.meta.clamped).sum::<u64>();
    Ok(Part {
        meta: out_meta,
        mean,
        variance,
        count,
        weight,
        channels: names,
        extras,
        denoised: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PartMeta;

    fn part(crop: (u32, u32, u32, u32), samples: (u32, u32), value: f32) -> Part {
        let n = (crop.2 * crop.3) as usize;
        Part {
            meta: PartMeta {
                scene: "s.xml".into(),
                scene_hash: "0123456789abcdef".into(),
                settings: "seed=0".into(),
                width: 4,
                height: 2,
                spp: 8,
                samples,
                crop,
                nonfinite: 1,
                clamped: 0,
            },
            mean: vec![Vec3::splat(value); n],
            variance: vec![Vec3::ZERO; n],
            count: vec![samples.1 - samples.0; n],
            weight: vec![(samples.1 - samples.0) as f32; n],
            channels: Vec::new(),
            extras: Vec::new(),
            denoised: None,
        }
    }

    fn named(parts: Vec<Part>) -> Vec<(String, Part)> {
        parts
            .into_iter()
            .enumerate()
            .map(|(i, p)| (format!("part{i}"), p))
            .collect()
    }

    /// Two sample ranges of constant values 1 (3 samples) and 3 (5 samples): mean 2.25, and the
    /// variance of the mean from the between-range spread: M2 = 4 * 3 * 5 / 8 = 7.5, 7.5 / 56.
    #[test]
    fn ranges_merge_by_count_and_crops_by_place() {
        let parts = named(vec![
            part((0, 0, 2, 2), (3, 8), 3.0),
            part((0, 0, 2, 2), (0, 3), 1.0),
            part((2, 0, 2, 2), (0, 8), 5.0),
        ]);
        let m = merge(&parts).unwrap();
        assert_eq!(m.meta.crop, (0, 0, 4, 2));
        assert_eq!(m.meta.samples, (0, 8));
        assert_eq!(m.meta.nonfinite, 3);
        assert_eq!(m.mean[0], Vec3::splat(2.25));
        assert_eq!(m.mean[3], Vec3::splat(5.0));
        assert!((m.variance[4].x - 7.5 / 56.0).abs() < 1e-7);
        assert_eq!(m.variance[2], Vec3::ZERO);
    }

    /// Splatted pixels (weight sums other than the counts) merge by weight: means 1 and 3 with
    /// weights 2.5 and 1.5 give 1.75; variances 0.1 and 0.2 give (6.25 0.1 + 2.25 0.2) / 16.
    #[test]
    fn weighted_pixels_merge_by_weight_sums() {
        let mut a = part((0, 0, 4, 2), (0, 4), 1.0);
        let mut b = part((0, 0, 4, 2), (4, 8), 3.0);
        a.weight = vec![2.5; 8];
        b.weight = vec![1.5; 8];
        a.variance = vec![Vec3::splat(0.1); 8];
        b.variance = vec![Vec3::splat(0.2); 8];
        let m = merge(&named(vec![a, b])).unwrap();
        assert!((m.mean[5].x - 1.75).abs() < 1e-6, "{:?}", m.mean[5]);
        assert!((m.variance[5].y - (6.25 * 0.1 + 2.25 * 0.2) / 16.0).abs() < 1e-7);
        assert_eq!((m.count[5], m.weight[5]), (8, 4.0));
    }

    /// Sample ranges whose means are 0 and 3.4e38: the merged variance of the mean (their
    /// spread) is beyond f32's range, so it is clamped to f32::MAX and counted, and the parts'
    /// own counts add up; in f32 it was infinite. A weighted merge whose sum leaves the range
    /// (a negative weight) is clamped the same way.
    #[test]
    fn merged_values_beyond_f32_are_clamped_and_counted() {
        let mut a = part((0, 0, 4, 2), (0, 4), 0.0);
        let b = part((0, 0, 4, 2), (4, 8), 3.4e38);
        a.meta.clamped = 2;
        let m = merge(&named(vec![a, b])).unwrap();
        assert_eq!(m.mean[0], Vec3::splat(1.7e38));
        assert_eq!(m.variance[0], Vec3::splat(f32::MAX));
        assert_eq!(m.meta.clamped, 8 + 2);
        let mut a = part((0, 0, 4, 2), (0, 4), 3.4e38);
        let b = part((0, 0, 4, 2), (4, 8), 0.0);
        a.weight = vec![2.0; 8];
        let mut b = b;
        b.weight = vec![-1.0; 8];
        let m = merge(&named(vec![a, b])).unwrap();
        assert_eq!(m.mean[7], Vec3::splat(f32::MAX));
        assert!(m.variance.iter().all(|v| v.is_finite()));
        assert_eq!(m.meta.clamped, 8);
    }

    #[test]
    fn parts_that_do_not_fit_together_are_refused() {
        let cases: Vec<(Vec<Part>, &str)> = vec![
            (
                vec![
                    part((0, 0, 4, 2), (0, 5), 1.0),
                    part((0, 0, 4, 2), (4, 8), 1.0),
                ],
                "part0 and part1 overlap: both hold samples 4..5 of crop 0,0,4,2",
            ),
            (
                vec![
                    part((0, 0, 4, 2), (0, 3), 1.0),
                    part((0, 0, 4, 2), (4, 8), 1.0),
                ],
                "missing samples 3..4 of crop 0,0,4,2",
            ),
            (
                vec![part((0, 0, 4, 2), (0, 6), 1.0)],
                "missing samples 6..8 of crop 0,0,4,2",
            ),
            (
                vec![
                    part((0, 0, 2, 2), (0, 8), 1.0),
                    part((2, 0, 2, 1), (0, 8), 1.0),
                ],
                "missing pixels: no part covers 2 pixels of the 4x2 film, the first at 2,1",
            ),
            (
                vec![
                    part((0, 0, 3, 2), (0, 8), 1.0),
                    part((2, 0, 2, 2), (0, 8), 1.0),
                ],
                "overlap at pixel 2,0",
            ),
            (vec![], "no parts"),
        ];
        for (parts, message) in cases {
            let err = merge(&named(parts)).unwrap_err();
            assert!(err.contains(message), "{err}\nexpected: {message}");
        }
        let mut other = part((0, 0, 4, 2), (4, 8), 1.0);
        other.meta.scene_hash = "fedcba9876543210".into();
        let err = merge(&named(vec![part((0, 0, 4, 2), (0, 4), 1.0), other])).unwrap_err();
        assert!(
            err.contains("part1 does not belong with part0: other scene contents"),
            "{err}"
        );
        let mut other = part((0, 0, 4, 2), (4, 8), 1.0);
        other.meta.settings = "seed=1".into();
        let err = merge(&named(vec![part((0, 0, 4, 2), (0, 4), 1.0), other])).unwrap_err();
        assert!(
            err.contains("other settings ('seed=1' vs 'seed=0')"),
            "{err}"
        );
    }

    /// Channel values (AOVs, guides) merge as count-weighted means, matched by name whatever
    /// their order in each part; parts with other channels are refused.
    #[test]
    fn channels_merge_by_count_and_name() {
        let mut a = part((0, 0, 4, 2), (0, 2), 1.0);
        let mut b = part((0, 0, 4, 2), (2, 8), 1.0);
        a.channels = vec!["dd.T".into(), "albedo.R".into()];
        a.extras = [4.0, 0.5].repeat(8);
        b.channels = vec!["albedo.R".into(), "dd.T".into()];
        b.extras = [0.25, 8.0].repeat(8);
        let m = merge(&named(vec![a.clone(), b])).unwrap();
        assert_eq!(m.channels, ["dd.T", "albedo.R"]);
        assert_eq!(
            &m.extras[6..8],
            &[
                (2.0 * 4.0 + 6.0 * 8.0) / 8.0,
                (2.0 * 0.5 + 6.0 * 0.25) / 8.0
            ]
        );
        let mut c = part((0, 0, 4, 2), (2, 8), 1.0);
        c.channels = vec!["dd.T".into()];
        c.extras = vec![1.0; 8];
        let err = merge(&named(vec![a, c])).unwrap_err();
        assert!(err.contains("other channels"), "{err}");
    }

    /// A part survives the EXR round trip: pixels bit for bit, metadata field for field.
    #[test]
    fn part_exr_round_trip() {
        let mut p = part((1, 0, 3, 2), (2, 7), 0.1);
        p.mean[4] = Vec3::new(1e-7, 3.5, 1e9);
        p.variance[1] = Vec3::new(0.25, 1e-12, 7.0);
        p.weight[2] = -0.375;
        p.meta.scene = "/tmp/scènes/a b\\c\nd=e.xml".into();
        p.meta.clamped = 3;
        p.channels = vec!["nn.X".into(), "dd.y.T".into()];
        p.extras = (0..12).map(|i| i as f32 * 0.5).collect();
        p.denoised = Some(vec![Vec3::splat(0.3); 6]);
        let bytes = crate::write_part_bytes(&p).unwrap();
        let q = crate::read_part_bytes(&bytes, "mem").unwrap();
        assert_eq!(q.meta, p.meta);
        assert_eq!(q.mean, p.mean);
        assert_eq!(q.variance, p.variance);
        assert_eq!(q.count, p.count);
        assert_eq!(q.weight, p.weight);
        assert_eq!(q.denoised, p.denoised);
        // Channels come back in the file's (sorted) order.
        assert_eq!(q.channels, ["dd.y.T", "nn.X"]);
        assert_eq!(q.channel_values(&["nn.X", "dd.y.T"]).unwrap(), p.extras);
        let err = crate::read_part_bytes(b"not an exr", "junk.exr").unwrap_err();
        assert!(err.starts_with("junk.exr: not a readable EXR"), "{err}");
        // A part holding an infinite or NaN value was not written by torrey: refused, so that it
        // cannot spread into a merge.
        for (bad, variance) in [(f32::INFINITY, false), (f32::NAN, true)] {
            let mut r = p.clone();
            if variance {
                r.variance[3].y = bad;
            } else {
                r.mean[3].z = bad;
            }
            let bytes = crate::write_part_bytes(&r).unwrap();
            let err = crate::read_part_bytes(&bytes, "bad.exr").unwrap_err();
            // With a denoised image the mean is in `noisy.*`.
            let channel = if variance { "variance.G" } else { "noisy.B" };
            assert_eq!(
                err,
                format!("bad.exr: a value of {bad} in the '{channel}' channel")
            );
        }
    }
}
