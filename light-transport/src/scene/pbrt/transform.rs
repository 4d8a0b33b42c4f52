//! The transformations of the pbrt format as glam matrices (column vectors, `M · p`), with pbrt's
//! conventions: `Transform`/`ConcatTransform` list the 16 numbers column by column (translation in
//! the 13th–15th), `Rotate` takes degrees about an axis, and `LookAt` builds pbrt's *left-handed*
//! camera frame (`right = up × dir`) and returns the world-to-camera matrix.

use crate::math::{DMat4, DVec3};
use glam::{DMat3, DVec4};

/// The matrix of `Transform [ m00 … m33 ]` (column-major, as pbrt reads it).
pub(crate) fn from_pbrt(m: &[f64; 16]) -> DMat4 {
    DMat4::from_cols_array(m)
}

/// `Translate dx dy dz`.
pub(crate) fn translate(d: DVec3) -> DMat4 {
    DMat4::from_translation(d)
}

/// `Scale sx sy sz`.
pub(crate) fn scale(s: DVec3) -> DMat4 {
    DMat4::from_scale(s)
}

/// `Rotate angle x y z` (degrees, right-hand rule about the axis); `None` for a zero axis.
pub(crate) fn rotate(degrees: f64, axis: DVec3) -> Option<DMat4> {
    let len = axis.length();
    (len > 0.0 && len.is_finite()).then(|| DMat4::from_axis_angle(axis / len, degrees.to_radians()))
}

/// `LookAt eye look up`: pbrt's world-to-camera matrix. The camera frame has `+z` towards `look`,
/// `+x = normalize(up × dir)` and `+y = dir × x`. `Err` names the degeneracy.
pub(crate) fn look_at(eye: DVec3, look: DVec3, up: DVec3) -> Result<DMat4, &'static str> {
    let dir = look - eye;
    if dir.length_squared() == 0.0 {
        return Err("the eye and look-at points coincide");
    }
    let dir = dir.normalize();
    if up.length_squared() == 0.0 {
        return Err("the up vector is zero");
    }
    let right = up.normalize().cross(dir);
    if right.length() < 1e-12 {
        return Err("the up vector is parallel to the viewing direction");
    }
    let right = right.normalize();
    let new_up = dir.cross(right);
    let camera_to_world = DMat4::from_cols(
        right.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        eye.extend(1.0),
    );
    Ok(camera_to_world.inverse())
}

/// Whether the matrix is affine (last row `0 0 0 1`).
pub(crate) fn is_affine(m: &DMat4) -> bool {
    m.row(3) == DVec4::new(0.0, 0.0, 0.0, 1.0)
}

/// The linear 3×3 part.
pub(crate) fn linear(m: &DMat4) -> DMat3 {
    DMat3::from_mat4(*m)
}

/// Whether the transform mirrors space (pbrt's `SwapsHandedness`).
pub(crate) fn swaps_handedness(m: &DMat4) -> bool {
    linear(m).determinant() < 0.0
}

/// The inverse, when the matrix is invertible with a finite result.
pub(crate) fn checked_inverse(m: &DMat4) -> Option<DMat4> {
    let det = m.determinant();
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = m.inverse();
    inv.is_finite().then_some(inv)
}

/// The matrix that maps object-space normals to world space (`(L⁻¹)ᵀ`), when `L` is invertible.
pub(crate) fn normal_matrix(m: &DMat4) -> Option<DMat3> {
    let l = linear(m);
    let det = l.determinant();
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let n = l.inverse().transpose();
    n.is_finite().then_some(n)
}

/// If the linear part is a similarity (rotation or reflection times a uniform scale `s > 0`),
/// return `s`; otherwise the three axis scale factors, for the error message.
pub(crate) fn similarity_scale(m: &DMat4) -> Result<f64, [f64; 3]> {
    let l = linear(m);
    let c = [l.x_axis, l.y_axis, l.z_axis];
    let sq = c.map(|v| v.length_squared());
    let s2 = (sq[0] + sq[1] + sq[2]) / 3.0;
    let tol = 1e-5 * s2;
    let uniform = sq.iter().all(|&q| (q - s2).abs() <= tol);
    let orthogonal =
        c[0].dot(c[1]).abs() <= tol && c[1].dot(c[2]).abs() <= tol && c[0].dot(c[2]).abs() <= tol;
    if s2 > 0.0 && s2.is_finite() && uniform && orthogonal {
        Ok(s2.sqrt())
    } else {
        Err(sq.map(f64::sqrt))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-12
    }

    #[test]
    fn pbrt_conventions() {
        let t = from_pbrt(&[
            1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 5., 6., 7., 1.,
        ]);
        assert!(close(
            t.transform_point3(DVec3::ZERO),
            DVec3::new(5., 6., 7.)
        ));
        let r = rotate(90.0, DVec3::Z).unwrap();
        assert!(close(r.transform_point3(DVec3::X), DVec3::Y));
        assert!(rotate(10.0, DVec3::ZERO).is_none());
        // pbrt's canonical LookAt down +z with y up is the identity.
        let w2c = look_at(DVec3::ZERO, DVec3::Z, DVec3::Y).unwrap();
        assert!(w2c.abs_diff_eq(DMat4::IDENTITY, 1e-12));
        // Looking down -z with y up: pbrt's camera +x is world -x (left-handed frame).
        let w2c = look_at(DVec3::ZERO, -DVec3::Z, DVec3::Y).unwrap();
        assert!(close(w2c.transform_vector3(-DVec3::X), DVec3::X));
        assert!(look_at(DVec3::ZERO, DVec3::Y, DVec3::Y).is_err());
        assert!(look_at(DVec3::ONE, DVec3::ONE, DVec3::Y).is_err());
    }

    #[test]
    fn similarity_detection() {
        let m = translate(DVec3::ONE) * rotate(30.0, DVec3::new(1., 2., 3.)).unwrap();
        assert!((similarity_scale(&(m * scale(DVec3::splat(2.0)))).unwrap() - 2.0).abs() < 1e-12);
        assert!((similarity_scale(&scale(DVec3::new(-3., 3., 3.))).unwrap() - 3.0).abs() < 1e-12);
        assert!(swaps_handedness(&scale(DVec3::new(-3., 3., 3.))));
        assert!(similarity_scale(&scale(DVec3::new(1., 2., 1.))).is_err());
        assert!(similarity_scale(&scale(DVec3::ZERO)).is_err());
    }
}
