//! Pinhole cameras in the two pose conventions users have.
//!
//! * [`PoseConvention::Mitsuba`] (`transforms.json`): camera +X = image left, +Y = up,
//!   +Z = forward. Pixel centre (u, v) looks along R·(−(u−cx)/fx, −(v−cy)/fy, 1).
//! * [`PoseConvention::OpenCv`] (`cam.txt` + `K_list.txt`): +X = right, +Y = down, +Z = forward.
//!   Pixel centre (u, v) looks along R·((u−cx)/fx, (v−cy)/fy, 1).
//!
//! Pixel (i, j) has its centre at (u, v) = (i + 0.5, j + 0.5); j counts rows from the top.
//!
//! A camera may carry a lens model ([`Distortion`]): rays and projections go through it, on
//! the normalised OpenCV-axes coordinates ((u−cx)/fx, (v−cy)/fy).
use crate::distortion::Distortion;
use glam::{Mat3, Mat4, Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// Which camera-space axes a camera-to-world rotation maps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PoseConvention {
    /// +X left, +Y up, +Z forward (Mitsuba / FIPT `transforms.json`).
    Mitsuba,
    /// +X right, +Y down, +Z forward (OpenCV / COLMAP).
    OpenCv,
}

/// A pinhole camera: intrinsics, image size and camera-to-world pose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    pub width: usize,
    pub height: usize,
    pub fx: f32,
    pub fy: f32,
    pub cx: f32,
    pub cy: f32,
    pub convention: PoseConvention,
    /// Camera-to-world rotation (columns: the camera's axes in world space, in `convention`).
    pub rotation: Mat3,
    /// Camera centre in world space.
    pub origin: Vec3,
    /// The lens model (none: a pinhole).
    #[serde(default, skip_serializing_if = "Distortion::is_none")]
    pub distortion: Distortion,
}

/// Sign flip between the two conventions: Mitsuba axes = OpenCV axes · diag(−1, −1, 1).
const FLIP_XY: Mat3 = Mat3::from_cols(Vec3::NEG_X, Vec3::NEG_Y, Vec3::Z);

impl Camera {
    /// A camera from a `transforms.json` frame: 4×4 camera-to-world (Mitsuba convention) and
    /// horizontal field of view; principal point at the image centre, square pixels.
    pub fn from_transform(c2w: Mat4, camera_angle_x: f32, width: usize, height: usize) -> Self {
        let f = 0.5 * width as f32 / (0.5 * camera_angle_x).tan();
        Camera {
            width,
            height,
            fx: f,
            fy: f,
            cx: 0.5 * width as f32,
            cy: 0.5 * height as f32,
            convention: PoseConvention::Mitsuba,
            rotation: Mat3::from_mat4(c2w),
            origin: c2w.w_axis.truncate(),
            distortion: Distortion::None,
        }
    }

    /// A Mitsuba-convention camera at `origin` looking at `target` with world `up`.
    pub fn look_at(
        origin: Vec3,
        target: Vec3,
        up: Vec3,
        fov_x: f32,
        width: usize,
        height: usize,
    ) -> Self {
        let rot = look_at_rotation_opencv(origin, target, up) * FLIP_XY;
        let c2w = Mat4::from_cols(
            rot.x_axis.extend(0.0),
            rot.y_axis.extend(0.0),
            rot.z_axis.extend(0.0),
            origin.extend(1.0),
        );
        Camera::from_transform(c2w, fov_x, width, height)
    }

    /// An OpenCV-convention camera from `cam.txt` (origin, look-at, up) and a 3×3 `K`
    /// (row-major: `k[0] = [fx, 0, cx]`, `k[1] = [0, fy, cy]`).
    pub fn from_opencv(
        origin: Vec3,
        target: Vec3,
        up: Vec3,
        k: [[f32; 3]; 3],
        width: usize,
        height: usize,
    ) -> Self {
        Camera {
            width,
            height,
            fx: k[0][0],
            fy: k[1][1],
            cx: k[0][2],
            cy: k[1][2],
            convention: PoseConvention::OpenCv,
            rotation: look_at_rotation_opencv(origin, target, up),
            origin,
            distortion: Distortion::None,
        }
    }

    /// Camera-space direction (not normalised) through continuous pixel coordinates (u, v).
    #[inline]
    pub fn local_direction(&self, u: f32, v: f32) -> Vec3 {
        let x = (u - self.cx) / self.fx;
        let y = (v - self.cy) / self.fy;
        let d = self.distortion.direction(Vec2::new(x, y));
        match self.convention {
            PoseConvention::Mitsuba => Vec3::new(-d.x, -d.y, d.z),
            PoseConvention::OpenCv => d,
        }
    }

    /// World-space ray (origin, unit direction) through continuous pixel coordinates (u, v).
    #[inline]
    pub fn ray(&self, u: f32, v: f32) -> (Vec3, Vec3) {
        (
            self.origin,
            (self.rotation * self.local_direction(u, v)).normalize(),
        )
    }

    /// The ray through the centre of pixel (i, j).
    #[inline]
    pub fn pixel_center_ray(&self, i: usize, j: usize) -> (Vec3, Vec3) {
        self.ray(i as f32 + 0.5, j as f32 + 0.5)
    }

    /// Continuous pixel coordinates of a world point, or None behind the camera.
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let local = self.rotation.transpose() * (p - self.origin);
        let local = match self.convention {
            PoseConvention::Mitsuba => Vec3::new(-local.x, -local.y, local.z),
            PoseConvention::OpenCv => local,
        };
        let q = self.distortion.project(local)?;
        Some(Vec2::new(q.x * self.fx + self.cx, q.y * self.fy + self.cy))
    }

    /// The same camera for images downscaled by `factor` (each output pixel the mean of a
    /// `factor`×`factor` block, the remainder cropped at the right and bottom): intrinsics in
    /// pixels divided by it, exactly, since pixel coordinates start at the image's corner.
    pub fn downscaled(&self, factor: usize) -> Camera {
        let s = factor.max(1) as f32;
        let mut c = self.clone();
        c.width = self.width / factor.max(1);
        c.height = self.height / factor.max(1);
        c.fx /= s;
        c.fy /= s;
        c.cx /= s;
        c.cy /= s;
        c
    }

    /// The same camera for images enlarged `factor` times (each pixel a `factor`×`factor`
    /// block): the inverse of [`Camera::downscaled`].
    pub fn upscaled(&self, factor: usize) -> Camera {
        let s = factor.max(1) as f32;
        let mut c = self.clone();
        c.width = self.width * factor.max(1);
        c.height = self.height * factor.max(1);
        c.fx *= s;
        c.fy *= s;
        c.cx *= s;
        c.cy *= s;
        c
    }

    /// The largest normalised radius (on the distorted plane) any pixel of the image reaches.
    pub fn max_normalised_radius(&self) -> f32 {
        let corners = [
            (0.0, 0.0),
            (self.width as f32, 0.0),
            (0.0, self.height as f32),
            (self.width as f32, self.height as f32),
        ];
        corners
            .iter()
            .map(|&(u, v)| Vec2::new((u - self.cx) / self.fx, (v - self.cy) / self.fy).length())
            .fold(0.0, f32::max)
    }

    /// Viewing direction (unit vector along the optical axis) in world space.
    pub fn forward(&self) -> Vec3 {
        self.rotation.z_axis.normalize()
    }

    /// Camera-to-world in the Mitsuba convention, as written to `transforms.json`.
    pub fn to_mitsuba_matrix(&self) -> Mat4 {
        let r = match self.convention {
            PoseConvention::Mitsuba => self.rotation,
            PoseConvention::OpenCv => self.rotation * FLIP_XY,
        };
        Mat4::from_cols(
            r.x_axis.extend(0.0),
            r.y_axis.extend(0.0),
            r.z_axis.extend(0.0),
            self.origin.extend(1.0),
        )
    }

    /// Horizontal field of view in radians.
    pub fn fov_x(&self) -> f32 {
        2.0 * (0.5 * self.width as f32 / self.fx).atan()
    }

    /// The camera as `cam.txt` and `K_list.txt` hold it: origin, a look-at point one unit
    /// ahead, the up vector (−Y of the OpenCV axes) and K (row-major).
    pub fn to_opencv_lookat(&self) -> (Vec3, Vec3, Vec3, [[f32; 3]; 3]) {
        let r = match self.convention {
            PoseConvention::OpenCv => self.rotation,
            PoseConvention::Mitsuba => self.rotation * FLIP_XY,
        };
        let k = [
            [self.fx, 0.0, self.cx],
            [0.0, self.fy, self.cy],
            [0.0, 0.0, 1.0],
        ];
        (self.origin, self.origin + r.z_axis, -r.y_axis, k)
    }

    /// The same camera moved by `offset` and turned by `turn` (a world-space rotation about
    /// its centre): a pose off by a known amount.
    pub fn moved(&self, offset: Vec3, turn: Mat3) -> Camera {
        let mut c = self.clone();
        c.origin += offset;
        c.rotation = turn * self.rotation;
        c
    }

    /// Deviation of the rotation from a proper rotation: (max |RᵀR − I|, det R).
    pub fn rotation_error(&self) -> (f32, f32) {
        rotation_error(self.rotation)
    }
}

/// (max |RᵀR − I|, det R) of a 3×3 matrix.
pub fn rotation_error(r: Mat3) -> (f32, f32) {
    let rtr = r.transpose() * r;
    let mut err = 0.0f32;
    for (c, e) in [rtr.x_axis, rtr.y_axis, rtr.z_axis]
        .iter()
        .zip([Vec3::X, Vec3::Y, Vec3::Z])
    {
        err = err.max((*c - e).abs().max_element());
    }
    (err, r.determinant())
}

/// OpenCV-convention camera-to-world rotation (right, down, forward) for a look-at.
fn look_at_rotation_opencv(origin: Vec3, target: Vec3, up: Vec3) -> Mat3 {
    let z = (target - origin).normalize();
    let mut up_perp = up - up.dot(z) * z;
    if up_perp.length_squared() < 1e-12 {
        // Looking along `up`: pick any perpendicular.
        up_perp = z.any_orthonormal_vector();
    }
    let y = -up_perp.normalize();
    let x = y.cross(z);
    Mat3::from_cols(x, y, z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mitsuba_pixel_convention_left_up_forward() {
        // Camera at origin looking down world +Z with world up +Y: camera +X (image left)
        // is world +X (right-handed: left × up = forward).
        let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 90f32.to_radians(), 4, 2);
        assert!(
            (cam.rotation.x_axis - Vec3::X).length() < 1e-6,
            "{:?}",
            cam.rotation
        );
        assert!((cam.rotation.y_axis - Vec3::Y).length() < 1e-6);
        // Pixel column 0 is on the image's left, i.e. world +X; row 0 is up.
        let (_, d) = cam.pixel_center_ray(0, 0);
        assert!(d.x > 0.0 && d.y > 0.0 && d.z > 0.0, "{d}");
        // fov 90°, W = 4: f = 2; pixel centre u = 0.5 → x = -0.75.
        let expected = Vec3::new(0.75, 0.25, 1.0).normalize();
        assert!((d - expected).length() < 1e-6);
    }

    #[test]
    fn opencv_and_mitsuba_agree_on_the_same_physical_camera() {
        let o = Vec3::new(0.3, 1.2, -0.5);
        let t = Vec3::new(1.0, 0.8, 2.0);
        let mi = Camera::look_at(o, t, Vec3::Y, 60f32.to_radians(), 64, 48);
        let k = [[mi.fx, 0.0, mi.cx], [0.0, mi.fy, mi.cy], [0.0, 0.0, 1.0]];
        let cv = Camera::from_opencv(o, t, Vec3::Y, k, 64, 48);
        for (i, j) in [(0, 0), (63, 0), (10, 47), (32, 24)] {
            let (_, a) = mi.pixel_center_ray(i, j);
            let (_, b) = cv.pixel_center_ray(i, j);
            assert!((a - b).length() < 1e-5, "pixel ({i},{j}): {a} vs {b}");
        }
        assert!((mi.to_mitsuba_matrix() - cv.to_mitsuba_matrix()).abs_diff_eq(Mat4::ZERO, 1e-5));
        let (err, det) = cv.rotation_error();
        assert!(err < 1e-5 && (det - 1.0).abs() < 1e-5);
        // And back through cam.txt's look-at form.
        let (o2, t2, up2, k2) = mi.to_opencv_lookat();
        let back = Camera::from_opencv(o2, t2, up2, k2, 64, 48);
        assert!((back.to_mitsuba_matrix() - mi.to_mitsuba_matrix()).abs_diff_eq(Mat4::ZERO, 1e-5));
    }

    #[test]
    fn project_inverts_ray() {
        let cam = Camera::look_at(
            Vec3::new(1.0, 1.5, 2.0),
            Vec3::new(-1.0, 0.5, -1.0),
            Vec3::Y,
            1.1,
            240,
            160,
        );
        for (u, v) in [(0.5, 0.5), (120.0, 80.0), (239.5, 159.5), (17.25, 99.75)] {
            let (o, d) = cam.ray(u, v);
            let p = cam.project(o + 3.7 * d).unwrap();
            assert!((p - Vec2::new(u, v)).length() < 1e-3, "{p} vs ({u},{v})");
        }
        assert!(cam.project(cam.origin - cam.forward()).is_none());
        assert!((cam.fov_x() - 1.1).abs() < 1e-6);
    }
}
