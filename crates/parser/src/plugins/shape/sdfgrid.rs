//! Mitsuba's `sdfgrid`.

use crate::context::Ctx;
use crate::error::Result;
use crate::files::input_file;
use crate::props::Props;
use crate::xml::Element;
use glam::{Mat3, Mat4};

/// Mitsuba's `sdfgrid`: a `.vol` grid of one channel (read by [`crate::vol`]) whose samples
/// span [0, 1]^3 in object space, the file's own bounding box ignored, as Mitsuba 3.9.1 does.
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `filename` | string | required: a `.vol` file (version 3, float32, one channel, at least 2 samples along each axis, finite values, at least one voxel whose corners are not all of one sign) |
/// | `normals` | string | `smooth` (Hansson-Söderlund et al.'s blend of the gradients of the voxels around the hit, continuous across voxels) or `analytic` (the gradient of the trilinear interpolant in the hit's voxel) |
/// | `to_world` | transform | identity |
///
/// Not parameters of Mitsuba's `sdfgrid`: `flip_normals` (Mitsuba reports it unreferenced;
/// here it is warned about and ignored), an area emitter (an error: Mitsuba cannot sample one
/// on it), uvs (hits have uv 0).
pub(super) fn sdf_grid(
    ctx: &mut Ctx,
    props: &mut Props,
    elem: &Element,
    to_world: Mat4,
) -> Result<std::sync::Arc<crate::scene::SdfGrid>> {
    let Some(file) = props.string(ctx, &["filename"])? else {
        return Err(ctx.err(
            elem.pos,
            "missing required parameter 'filename' of shape 'sdfgrid' (a .vol file)",
        ));
    };
    let smooth_normals = match props.string(ctx, &["normals"])? {
        None => true,
        Some(a) => match a.value.as_str() {
            "smooth" => true,
            "analytic" => false,
            v => {
                return Err(ctx.err(
                    a.value_pos,
                    format!(
                    "unknown normals mode '{v}' of shape 'sdfgrid' (expected smooth or analytic)"
                ),
                ))
            }
        },
    };
    let path = input_file(ctx, file, "sdfgrid")?;
    let in_file = |ctx: &Ctx, m: String| {
        ctx.err(
            file.value_pos,
            format!("in sdfgrid file '{}': {m}", file.value),
        )
    };
    let budget = ctx.limits.volume_values.saturating_sub(ctx.volume_values);
    let grid = crate::vol::read_vol_file(&path, budget).map_err(|e| in_file(ctx, e.0))?;
    if grid.channels != 1 {
        return Err(in_file(
            ctx,
            format!(
                "it has {} channels; an sdfgrid needs 1 (as in Mitsuba)",
                grid.channels
            ),
        ));
    }
    if grid.size.iter().any(|&s| s < 2) {
        let [x, y, z] = grid.size;
        return Err(in_file(
            ctx,
            format!("it has {x} x {y} x {z} samples; an sdfgrid needs at least 2 along each axis"),
        ));
    }
    if grid.trailing_bytes > 0 {
        ctx.warn(
            file.value_pos,
            format!(
                "sdfgrid file '{}' has {} bytes after its last value; ignored (as Mitsuba does)",
                file.value, grid.trailing_bytes
            ),
        );
    }
    let mut sdf = crate::scene::SdfGrid {
        size: grid.size,
        values: grid.data,
        smooth_normals,
        surface_voxels: 0,
    };
    let [nx, ny, nz] = sdf.size;
    let mut surface_voxels = 0u64;
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                surface_voxels += sdf.voxel_has_surface(i, j, k) as u64;
            }
        }
    }
    if surface_voxels == 0 {
        return Err(in_file(
            ctx,
            "no voxel has corner samples of both signs: the grid has no surface (Mitsuba: \"SDFGrid should at least have one non-empty voxel\")"
                .into(),
        ));
    }
    // Each voxel with surface is a primitive of the BVH, as a triangle is.
    if ctx.triangles.saturating_add(surface_voxels) > ctx.limits.mesh_triangles {
        return Err(in_file(
            ctx,
            format!(
            "its {surface_voxels} voxels with surface and the {} triangles before it make more primitives than the limit of {} (raise with --limit mesh_triangles=N)",
            ctx.triangles, ctx.limits.mesh_triangles
        ),
        ));
    }
    ctx.triangles += surface_voxels;
    ctx.volume_values += sdf.values.len() as u64;
    sdf.surface_voxels = surface_voxels;
    // Mitsuba 3.9.1 warns about rotations in an sdfgrid's to_world; its voxels' boxes then
    // ignore the rotation and it misses hits.
    let m = Mat3::from_mat4(to_world);
    let scale = m.to_cols_array().iter().fold(0.0f32, |a, v| a.max(v.abs()));
    let off_diagonal = [
        m.x_axis.y, m.x_axis.z, m.y_axis.x, m.y_axis.z, m.z_axis.x, m.z_axis.y,
    ];
    if off_diagonal.iter().any(|v| v.abs() > 1e-6 * scale) {
        ctx.warn(
            elem.pos,
            "the to_world of shape 'sdfgrid' rotates or shears it: torrey renders that, but Mitsuba 3.9.1 warns and can miss hits (its voxel boxes ignore the rotation); place the grid with a shapegroup and an instance to get the same picture from both",
        );
    }
    Ok(std::sync::Arc::new(sdf))
}
