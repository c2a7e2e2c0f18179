//! `<transform>` elements: translate, scale, rotate, matrix and lookat, composed in document
//! order (each op is applied after the previous ones: M = op_n ... op_1).

use crate::context::Ctx;
use crate::error::Result;
use crate::values;
use crate::xml::{Attr, Element};
use glam::{Affine2, Mat4, Vec2, Vec3, Vec4};

fn num(ctx: &Ctx, e: &Element, a: &Attr) -> Result<f32> {
    values::float(&a.value).map_err(|m| {
        ctx.err(
            a.value_pos,
            format!("{m} in attribute '{}' of <{}>", a.name, e.tag),
        )
    })
}

fn vector(ctx: &Ctx, e: &Element, a: &Attr) -> Result<Vec3> {
    values::vec3(&a.value).map_err(|m| {
        ctx.err(
            a.value_pos,
            format!("{m} in attribute '{}' of <{}>", a.name, e.tag),
        )
    })
}

/// `x`/`y`/`z` attributes with a default, or a `value` attribute (one value broadcasts).
fn xyz(ctx: &Ctx, e: &Element, default: f32) -> Result<Vec3> {
    if let Some(a) = e.attr("value") {
        return vector(ctx, e, a);
    }
    let mut v = Vec3::splat(default);
    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
        if let Some(a) = e.attr(axis) {
            v[i] = num(ctx, e, a)?;
        }
    }
    Ok(v)
}

fn required<'e>(ctx: &Ctx, e: &'e Element, name: &str) -> Result<&'e Attr> {
    e.attr(name).ok_or_else(|| {
        ctx.err(
            e.pos,
            format!("missing required attribute '{name}' on <{}>", e.tag),
        )
    })
}

/// Mitsuba 3's look-at frame: d = normalize(target - origin), left = normalize(up x d),
/// up' = d x left; camera +x = left, +y = up', +z = d, placed at origin.
pub(crate) fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> Option<Mat4> {
    let d = (target - origin).try_normalize()?;
    let left = up.cross(d).try_normalize()?;
    let new_up = d.cross(left);
    Some(Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        d.extend(0.0),
        origin.extend(1.0),
    ))
}

/// The up vector Mitsuba 3 gives a `lookat` without one: the first vector of its orthonormal
/// frame around the view direction d (Duff et al.'s branchless construction):
/// s = (1 + sign d.x^2 a, sign b, -sign d.x) with sign = copysign(1, d.z), a = -1 / (sign + d.z),
/// b = d.x d.y a.
pub(crate) fn generated_up(dir: Vec3) -> Vec3 {
    let d = dir.normalize_or_zero();
    let sign = 1f32.copysign(d.z);
    let a = -1.0 / (sign + d.z);
    let b = d.x * d.y * a;
    Vec3::new(1.0 + sign * d.x * d.x * a, sign * b, -sign * d.x)
}

/// Parses a `<transform>`. With `uv`, `rotate` without an axis turns about z, and a 9-entry
/// `matrix` is read as a 2D homogeneous matrix.
pub(crate) fn parse_transform(ctx: &Ctx, elem: &Element, uv: bool) -> Result<Mat4> {
    let mut m = Mat4::IDENTITY;
    for op in &elem.children {
        let t = match op.tag.to_ascii_lowercase().as_str() {
            "translate" => Mat4::from_translation(xyz(ctx, op, 0.0)?),
            "scale" => Mat4::from_scale(xyz(ctx, op, 1.0)?),
            "rotate" => {
                let mut axis = xyz(ctx, op, 0.0)?;
                if uv && axis == Vec3::ZERO {
                    axis = Vec3::Z;
                }
                let angle = num(ctx, op, required(ctx, op, "angle")?)?;
                let Some(axis) = axis.try_normalize() else {
                    return Err(ctx.err(op.pos, "<rotate> needs a non-zero axis (x, y, z)"));
                };
                Mat4::from_axis_angle(axis, angle.to_radians())
            }
            "matrix" => {
                let a = required(ctx, op, "value")?;
                let v = values::floats(&a.value).map_err(|m| {
                    ctx.err(a.value_pos, format!("{m} in attribute 'value' of <matrix>"))
                })?;
                match v.len() {
                    16 => Mat4::from_cols_array(&v.try_into().unwrap()).transpose(),
                    9 if uv => Mat4::from_cols(
                        Vec4::new(v[0], v[3], 0.0, v[6]),
                        Vec4::new(v[1], v[4], 0.0, v[7]),
                        Vec4::new(0.0, 0.0, 1.0, 0.0),
                        Vec4::new(v[2], v[5], 0.0, v[8]),
                    ),
                    n => {
                        return Err(ctx.err(
                            a.value_pos,
                            format!(
                                "<matrix> needs 16 numbers (row-major 4x4){}, found {n}",
                                if uv { " or 9 (3x3)" } else { "" }
                            ),
                        ))
                    }
                }
            }
            "lookat" => {
                let origin = vector(ctx, op, required(ctx, op, "origin")?)?;
                let target = vector(ctx, op, required(ctx, op, "target")?)?;
                let up = match op.attr("up") {
                    Some(a) => vector(ctx, op, a)?,
                    None => generated_up(target - origin),
                };
                if (target - origin).length_squared() == 0.0 {
                    return Err(ctx.err(op.pos, "<lookat>: origin equals target"));
                }
                look_at(origin, target, up).ok_or_else(|| {
                    ctx.err(
                        op.pos,
                        "<lookat>: up is parallel to the view direction (or zero)",
                    )
                })?
            }
            _ => {
                return Err(ctx.err(
                    op.pos,
                    format!(
                        "unknown tag <{}> in <transform> (expected translate, scale, rotate, matrix or lookat)",
                        op.tag
                    ),
                ))
            }
        };
        m = t * m;
        if !m.is_finite() {
            return Err(ctx.err(
                op.pos,
                format!(
                    "<{}> makes the transform overflow (an entry is no longer a finite 32-bit float)",
                    op.tag
                ),
            ));
        }
    }
    Ok(m)
}

/// Why `m` cannot place a camera or orient an environment map, if it cannot: it must be affine
/// (last row 0 0 0 1) and its 3x3 part must be invertible without being nearly singular,
/// with axis lengths between 1e-6 and 1e6. Directions mapped through a matrix with scale 0,
/// 1e-30 or 1e30 come out as zero, NaN or infinite.
pub(crate) fn frame_problem(m: Mat4) -> Option<String> {
    if !m.is_finite() {
        return Some("it is not finite".into());
    }
    let cols = [m.x_axis, m.y_axis, m.z_axis].map(|c| c.truncate().as_dvec3());
    let lengths = cols.map(|c| c.length());
    if let Some(l) = lengths
        .iter()
        .find(|l| !(1e-6f32 as f64..=1e6f32 as f64).contains(*l))
    {
        return Some(format!(
            "it scales an axis by {l:.3e} (a camera or environment transform may scale by 1e-6 to 1e6)"
        ));
    }
    if m.row(3) != Vec4::new(0.0, 0.0, 0.0, 1.0) {
        return Some("it is projective (the last row is not 0 0 0 1)".into());
    }
    let reach = m.w_axis.truncate().abs().max_element() as f64;
    if reach > crate::plugins::shape::WORLD_EXTENT {
        return Some(format!(
            "it places the origin {reach:.3e} away, beyond the {:e} torrey supports",
            crate::plugins::shape::WORLD_EXTENT
        ));
    }
    let volume = cols[0].dot(cols[1].cross(cols[2])).abs();
    if volume < 1e-6 * lengths.iter().product::<f64>() {
        return Some("it is singular (flattens space onto a plane or line)".into());
    }
    None
}

/// The 2D affine part of a 4x4 used as a `to_uv` transform: the upper-left 2x2 and the
/// x/y translation.
pub(crate) fn to_affine2(m: Mat4) -> Affine2 {
    Affine2::from_cols(
        m.x_axis.truncate().truncate(),
        m.y_axis.truncate().truncate(),
        Vec2::new(m.w_axis.x, m.w_axis.y),
    )
}
