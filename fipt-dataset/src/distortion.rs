//! Lens distortion, in the one place its formulas live: the Brown–Conrady model of OpenCV
//! (COLMAP's `SIMPLE_RADIAL`, `RADIAL`, `OPENCV`; nerfstudio's `OPENCV`) and the equidistant
//! fisheye model of Kannala–Brandt (COLMAP's and nerfstudio's `OPENCV_FISHEYE`).
//!
//! Both act on normalised image coordinates in the OpenCV axes (x right, y down, z forward):
//! a camera-space direction d is the point (d.x/d.z, d.y/d.z) on the plane z = 1, which the
//! lens moves to where the sensor records it; the pixel is then (fx·x + cx, fy·y + cy).
//! Rays are traced through the model ([`Distortion::direction`] inverts it by Newton's
//! method), so images are never resampled.
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// A lens model. [`Distortion::None`] is the pinhole: every method is the identity on it, bit
/// for bit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum Distortion {
    /// The pinhole: no distortion.
    #[default]
    None,
    /// Brown–Conrady: with r² = x² + y², radial factor 1 + k1·r² + k2·r⁴ + k3·r⁶,
    /// x_d = x·radial + 2·p1·x·y + p2·(r² + 2x²), y_d = y·radial + p1·(r² + 2y²) + 2·p2·x·y.
    Opencv {
        k1: f32,
        k2: f32,
        #[serde(default)]
        k3: f32,
        #[serde(default)]
        p1: f32,
        #[serde(default)]
        p2: f32,
    },
    /// Equidistant fisheye (Kannala–Brandt): θ the angle from the optical axis,
    /// θ_d = θ·(1 + k1·θ² + k2·θ⁴ + k3·θ⁶ + k4·θ⁸), and the point lies at radius θ_d on the
    /// normalised plane along the direction's azimuth. Covers θ up to 90° and beyond.
    Fisheye {
        k1: f32,
        #[serde(default)]
        k2: f32,
        #[serde(default)]
        k3: f32,
        #[serde(default)]
        k4: f32,
    },
}

/// Newton steps of the inverse; the residual is checked, not assumed.
const NEWTON_STEPS: usize = 20;
/// A normalised-plane residual below which the inverse has converged (≈ 1e-3 px at f = 1000).
const INVERSE_TOL: f32 = 1e-6;

impl Distortion {
    pub fn is_none(&self) -> bool {
        matches!(self, Distortion::None)
    }

    /// Where the lens records a camera-space direction (OpenCV axes): the distorted point on
    /// the normalised plane, or None for a direction it does not image (behind a pinhole or
    /// Brown–Conrady camera; beyond the fisheye's monotone range).
    #[inline]
    pub fn project(&self, d: Vec3) -> Option<Vec2> {
        match *self {
            Distortion::None | Distortion::Opencv { .. } => {
                if d.z <= 0.0 {
                    return None;
                }
                Some(self.distort(Vec2::new(d.x / d.z, d.y / d.z)))
            }
            Distortion::Fisheye { .. } => {
                let r = (d.x * d.x + d.y * d.y).sqrt();
                let theta = r.atan2(d.z);
                if theta > self.fisheye_limit() {
                    return None;
                }
                let td = self.theta_d(theta);
                if r <= 0.0 {
                    return Some(Vec2::ZERO);
                }
                Some(Vec2::new(d.x, d.y) * (td / r))
            }
        }
    }

    /// The camera-space direction (OpenCV axes, not normalised) whose image is the distorted
    /// normalised point `p`: the inverse of [`Distortion::project`]. For the pinhole it is
    /// (p.x, p.y, 1) exactly.
    #[inline]
    pub fn direction(&self, p: Vec2) -> Vec3 {
        match *self {
            Distortion::None => Vec3::new(p.x, p.y, 1.0),
            Distortion::Opencv { .. } => self.undistort(p).extend(1.0),
            Distortion::Fisheye { .. } => {
                let td = p.length();
                if td <= 0.0 {
                    return Vec3::Z;
                }
                let theta = self.theta_of(td);
                let (s, c) = theta.sin_cos();
                Vec3::new(p.x / td * s, p.y / td * s, c)
            }
        }
    }

    /// Brown–Conrady (or identity): undistorted normalised point → distorted one.
    #[inline]
    pub fn distort(&self, q: Vec2) -> Vec2 {
        match *self {
            Distortion::Opencv { k1, k2, k3, p1, p2 } => {
                let (x, y) = (q.x, q.y);
                let r2 = x * x + y * y;
                let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
                Vec2::new(
                    x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
                    y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
                )
            }
            Distortion::Fisheye { .. } => {
                self.project(q.extend(1.0)).unwrap_or(Vec2::splat(f32::NAN))
            }
            Distortion::None => q,
        }
    }

    /// The undistorted normalised point whose image is `p` (Brown–Conrady, by Newton's method
    /// on the 2×2 Jacobian, started at `p`).
    fn undistort(&self, p: Vec2) -> Vec2 {
        let Distortion::Opencv { k1, k2, k3, p1, p2 } = *self else {
            return p;
        };
        let mut q = p;
        for _ in 0..NEWTON_STEPS {
            let e = self.distort(q) - p;
            if e.length() < INVERSE_TOL * 0.01 {
                break;
            }
            let (x, y) = (q.x, q.y);
            let r2 = x * x + y * y;
            let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
            // d(radial)/dx = 2x·(k1 + 2k2 r² + 3k3 r⁴), likewise for y.
            let dr = 2.0 * (k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2));
            let a = radial + x * dr * x + 2.0 * p1 * y + 6.0 * p2 * x;
            let b = x * dr * y + 2.0 * p1 * x + 2.0 * p2 * y;
            let c = y * dr * x + 2.0 * p1 * x + 2.0 * p2 * y;
            let d = radial + y * dr * y + 6.0 * p1 * y + 2.0 * p2 * x;
            let det = a * d - b * c;
            if !det.is_finite() || det.abs() < 1e-12 {
                break;
            }
            q -= Vec2::new(d * e.x - b * e.y, -c * e.x + a * e.y) / det;
        }
        q
    }

    /// θ_d(θ) of the fisheye.
    #[inline]
    fn theta_d(&self, theta: f32) -> f32 {
        let Distortion::Fisheye { k1, k2, k3, k4 } = *self else {
            return theta.tan();
        };
        let t2 = theta * theta;
        theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
    }

    /// The largest θ (≤ π) up to which θ_d(θ) increases: beyond it the model folds over.
    fn fisheye_limit(&self) -> f32 {
        let Distortion::Fisheye { k1, k2, k3, k4 } = *self else {
            return std::f32::consts::FRAC_PI_2;
        };
        // dθ_d/dθ = 1 + 3k1θ² + 5k2θ⁴ + 7k3θ⁶ + 9k4θ⁸: scan for its first zero.
        let n = 256;
        for i in 1..=n {
            let t = std::f32::consts::PI * i as f32 / n as f32;
            let t2 = t * t;
            let slope = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
            if slope <= 0.0 {
                return std::f32::consts::PI * (i - 1) as f32 / n as f32;
            }
        }
        std::f32::consts::PI
    }

    /// θ with θ_d(θ) = `td` (Newton's method from θ = θ_d, kept inside the monotone range).
    fn theta_of(&self, td: f32) -> f32 {
        let Distortion::Fisheye { k1, k2, k3, k4 } = *self else {
            return td.atan();
        };
        let limit = self.fisheye_limit();
        let mut t = td.min(limit);
        for _ in 0..NEWTON_STEPS {
            let t2 = t * t;
            let f = self.theta_d(t) - td;
            if f.abs() < INVERSE_TOL * 0.01 {
                break;
            }
            let slope = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
            if slope <= 1e-6 {
                break;
            }
            t = (t - f / slope).clamp(0.0, limit);
        }
        t
    }

    /// Checks the coefficients (finite; the model invertible over the normalised radius
    /// `max_r` the image reaches): None when fine, else why not.
    // `!(err < bound)` is meant: it is true for NaN, which must fail the check too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn check(&self, max_r: f32) -> Option<String> {
        let coeffs: Vec<f32> = match *self {
            Distortion::None => return None,
            Distortion::Opencv { k1, k2, k3, p1, p2 } => vec![k1, k2, k3, p1, p2],
            Distortion::Fisheye { k1, k2, k3, k4 } => vec![k1, k2, k3, k4],
        };
        if coeffs.iter().any(|c| !c.is_finite()) {
            return Some(format!(
                "distortion coefficients {coeffs:?} are not all finite"
            ));
        }
        // Round trip at the image's corners and edges: the inverse must reproduce them, from
        // a ray on the same side of the axis, with the image growing outwards all the way (a
        // lens that folds the image over has a second, mirrored inverse).
        for i in 0..=16 {
            let a = std::f32::consts::TAU * i as f32 / 16.0;
            let p = Vec2::new(a.cos(), a.sin()) * max_r;
            let dir = self.direction(p);
            let back = self.project(dir);
            let err = back.map_or(f32::INFINITY, |b| (b - p).length());
            let (n, out) = (64, Vec2::new(dir.x, dir.y));
            let monotone = out.dot(p) > 0.0
                && (1..=n).all(|k| {
                    let at = |t: f32| {
                        let d = (out * t).extend(dir.z);
                        self.project(d).map_or(f32::NAN, |q| q.dot(p))
                    };
                    at(k as f32 / n as f32) > at((k - 1) as f32 / n as f32)
                });
            if !(err < 1e-4 * max_r.max(1.0)) || !monotone {
                return Some(format!(
                    "the distortion {self:?} cannot be inverted at the image's edge (normalised radius {max_r:.3}): \
                     the coefficients fold the image over; check them (k1 of a lens is usually within ±0.5)"
                ));
            }
        }
        None
    }
}

/// `opencv:K1[,K2,P1,P2,K3]`, `fisheye:K1[,K2,K3,K4]` or `pinhole` (the CLI's `--lens`).
impl std::str::FromStr for Distortion {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (model, coeffs) = s.split_once(':').unwrap_or((s, ""));
        let c: Vec<f32> = coeffs
            .split(',')
            .filter(|t| !t.trim().is_empty())
            .map(|t| t.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("{s}: the coefficients must be numbers (e.g. opencv:-0.12)"))?;
        let k = |i: usize| c.get(i).copied().unwrap_or(0.0);
        match model {
            "pinhole" | "none" if c.is_empty() => Ok(Distortion::None),
            "opencv" if (1..=5).contains(&c.len()) => Ok(Distortion::Opencv {
                k1: k(0),
                k2: k(1),
                p1: k(2),
                p2: k(3),
                k3: k(4),
            }),
            "fisheye" if (1..=4).contains(&c.len()) => Ok(Distortion::Fisheye {
                k1: k(0),
                k2: k(1),
                k3: k(2),
                k4: k(3),
            }),
            _ => Err(format!(
                "{s}: expected opencv:K1[,K2,P1,P2,K3], fisheye:K1[,K2,K3,K4] or pinhole"
            )),
        }
    }
}

impl Distortion {
    /// The model's coefficients by name (k1, k2, k3, p1, p2 or k1–k4; none for the pinhole).
    pub fn coefficients(&self) -> Vec<(&'static str, f32)> {
        match *self {
            Distortion::None => vec![],
            Distortion::Opencv { k1, k2, k3, p1, p2 } => {
                vec![("k1", k1), ("k2", k2), ("k3", k3), ("p1", p1), ("p2", p2)]
            }
            Distortion::Fisheye { k1, k2, k3, k4 } => {
                vec![("k1", k1), ("k2", k2), ("k3", k3), ("k4", k4)]
            }
        }
    }

    /// "k1 = -0.120, p1 = 0.001" after `lead` (", "): the non-zero coefficients ("" for none).
    pub fn nonzero_summary(&self, lead: &str) -> String {
        let list: Vec<String> = self
            .coefficients()
            .into_iter()
            .filter(|(_, v)| *v != 0.0)
            .map(|(n, v)| format!("{n} = {v:.3}"))
            .collect();
        if list.is_empty() {
            String::new()
        } else {
            format!("{lead}{}", list.join(", "))
        }
    }
}

/// A lens model in a few words: "pinhole", "opencv k1 -0.120 k2 0.000 …", "fisheye …".
pub fn describe(d: &Distortion) -> String {
    match *d {
        Distortion::None => "pinhole".into(),
        Distortion::Opencv { k1, k2, k3, p1, p2 } => {
            format!("opencv k1 {k1:.4} k2 {k2:.4} k3 {k3:.4} p1 {p1:.4} p2 {p2:.4}")
        }
        Distortion::Fisheye { k1, k2, k3, k4 } => {
            format!("fisheye k1 {k1:.4} k2 {k2:.4} k3 {k3:.4} k4 {k4:.4}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip(d: Distortion, max_r: f32) -> f32 {
        let mut worst = 0.0f32;
        for i in 0..40 {
            for j in 0..40 {
                let p = Vec2::new(i as f32 / 39.0 - 0.5, j as f32 / 39.0 - 0.5) * 2.0 * max_r;
                let back = d.project(d.direction(p)).unwrap();
                worst = worst.max((back - p).length());
            }
        }
        worst
    }

    #[test]
    fn pinhole_is_the_identity_bit_for_bit() {
        let d = Distortion::None;
        let p = Vec2::new(0.3127, -0.918);
        assert_eq!(d.direction(p), Vec3::new(p.x, p.y, 1.0));
        assert_eq!(d.distort(p), p);
        let v = Vec3::new(0.2, -0.7, 1.3);
        assert_eq!(d.project(v), Some(Vec2::new(v.x / v.z, v.y / v.z)));
        assert_eq!(d.project(-v), None);
    }

    #[test]
    fn brown_conrady_inverts_over_the_image() {
        for d in [
            Distortion::Opencv {
                k1: -0.12,
                k2: 0.0,
                k3: 0.0,
                p1: 0.0,
                p2: 0.0,
            },
            Distortion::Opencv {
                k1: 0.08,
                k2: -0.02,
                k3: 0.004,
                p1: 0.001,
                p2: -0.0015,
            },
            Distortion::Opencv {
                k1: -0.3,
                k2: 0.09,
                k3: 0.0,
                p1: 0.0,
                p2: 0.0,
            },
        ] {
            let e = round_trip(d, 0.7);
            assert!(e < 1e-5, "{d:?}: round trip off by {e}");
            assert!(d.check(0.9).is_none(), "{d:?}");
        }
    }

    #[test]
    fn barrel_distortion_pulls_the_corners_in() {
        let d = Distortion::Opencv {
            k1: -0.12,
            k2: 0.0,
            k3: 0.0,
            p1: 0.0,
            p2: 0.0,
        };
        let q = Vec2::new(0.5, 0.4);
        let r2 = q.length_squared();
        // Pure radial: x_d = x(1 + k1 r²).
        assert!((d.distort(q) - q * (1.0 - 0.12 * r2)).length() < 1e-7);
        assert!(d.distort(q).length() < q.length());
        // The ray through a distorted corner leaves wider than the pinhole's.
        let dir = d.direction(Vec2::new(0.6, 0.45));
        assert!(dir.x / dir.z > 0.6 && dir.y / dir.z > 0.45);
    }

    #[test]
    fn fisheye_inverts_past_ninety_degrees() {
        let d = Distortion::Fisheye {
            k1: 0.02,
            k2: -0.01,
            k3: 0.001,
            k4: 0.0,
        };
        assert!(round_trip(d, 1.2) < 1e-5);
        // θ_d = θ for the plain equidistant model: a ray at 100° off axis.
        let e = Distortion::Fisheye {
            k1: 0.0,
            k2: 0.0,
            k3: 0.0,
            k4: 0.0,
        };
        let theta = 100f32.to_radians();
        let dir = e.direction(Vec2::new(theta, 0.0));
        assert!((dir.normalize().z - theta.cos()).abs() < 1e-5, "{dir}");
        assert!((e.project(dir).unwrap().x - theta).abs() < 1e-5);
    }

    #[test]
    fn folding_coefficients_are_refused() {
        // 1 + k1 r² turns back before r = 1: the image folds over.
        let d = Distortion::Opencv {
            k1: -0.9,
            k2: 0.0,
            k3: 0.0,
            p1: 0.0,
            p2: 0.0,
        };
        assert!(d.check(1.0).is_some());
        let nan = Distortion::Fisheye {
            k1: f32::NAN,
            k2: 0.0,
            k3: 0.0,
            k4: 0.0,
        };
        assert!(nan.check(1.0).unwrap().contains("finite"));
    }
}
