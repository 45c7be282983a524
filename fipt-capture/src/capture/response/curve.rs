//! The curve a response fit works with: h(s) = (sRGB⁻¹(s) · e^{d(s)})^γ, d piecewise linear
//! on knots denser towards both ends, and its inverse by table.
use super::{HIGH, KNOTS, LOW};
use fipt_core::color::srgb_eotf;

/// An inverse response h(s) = (sRGB⁻¹(s) · e^{d(s)})^γ, d piecewise linear on the knots.
#[derive(Clone, Debug)]
pub(super) struct Curve {
    pub(super) d: Vec<f64>,
    pub(super) gamma: f64,
}

impl Curve {
    pub(super) fn srgb() -> Curve {
        Curve {
            d: vec![0.0; KNOTS + 1],
            gamma: 1.0,
        }
    }

    /// Stored value of knot k: denser towards both ends, where tone curves bend most (a
    /// shoulder compresses the top eighth of the stored values over a third of the linear
    /// ones); knot KNOTS/2 at 1/2.
    pub(super) fn knot(k: usize) -> f64 {
        let x = k as f64 / KNOTS as f64;
        0.5 * x + 0.25 * (1.0 - (std::f64::consts::PI * x).cos())
    }

    /// The knots and weights of d at stored value s.
    pub(super) fn weights(s: f64) -> [(usize, f64); 2] {
        let s = s.clamp(0.0, 1.0);
        let i = (1..KNOTS).take_while(|&k| Self::knot(k) <= s).count();
        let (a, b) = (Self::knot(i), Self::knot(i + 1));
        let f = ((s - a) / (b - a)).clamp(0.0, 1.0);
        [(i, 1.0 - f), (i + 1, f)]
    }

    pub(super) fn log_srgb(s: f64) -> f64 {
        (srgb_eotf(s.clamp(0.0, 1.0) as f32).max(1e-7) as f64).ln()
    }

    /// ln h(s).
    pub(super) fn log(&self, s: f64) -> f64 {
        let d: f64 = Self::weights(s).iter().map(|&(k, w)| w * self.d[k]).sum();
        self.gamma * (Self::log_srgb(s) + d)
    }

    pub(super) fn linear(&self, s: f64) -> f64 {
        if s <= 0.0 {
            0.0
        } else {
            self.log(s).exp().min(1.0)
        }
    }

    /// The weight of an observation at stored value s in a least-squares fit of ln h: the
    /// inverse square of sRGB's d ln h / ds there, so that residuals count in stored units
    /// (near enough for curves near sRGB; weights taken from the fitted curve itself let
    /// a fit hide its disagreement in steep stretches).
    pub(super) fn weight(s: f64) -> f64 {
        let e = 0.25 / KNOTS as f64;
        let (a, b) = ((s - e).max(1e-3), (s + e).min(1.0));
        let slope = (Self::log_srgb(b) - Self::log_srgb(a)) / (b - a);
        slope.powi(-2)
    }

    /// d ln h / ds at stored value s (of the segment it lies in; at least 1e-2).
    pub(super) fn log_slope(&self, s: f64) -> f64 {
        let [(i, _), (j, _)] = Self::weights(s);
        let (a, b) = (Self::knot(i), Self::knot(j));
        let at = |x: f64| self.log(x.max(1e-4));
        ((at(b) - at(a)) / (b - a)).max(1e-2)
    }

    /// The γ of h's family (h^γ) nearest sRGB: least squares of ln h against ln sRGB⁻¹ over
    /// the stored values used, weighed into stored units.
    pub(super) fn nearest_srgb_gamma(&self) -> f64 {
        let (mut num, mut den) = (0.0, 0.0);
        for k in 0..=64 {
            let s = LOW + (HIGH - LOW) * k as f64 / 64.0;
            let base = Self {
                gamma: 1.0,
                ..self.clone()
            };
            let (x, y) = (base.log(s), Self::log_srgb(s));
            let w = Self::weight(s);
            num += w * x * y;
            den += w * x * x;
        }
        if den > 0.0 {
            num / den
        } else {
            1.0
        }
    }

    /// RMS over 256 stored values of the linear values against sRGB's.
    pub(super) fn departure(&self) -> f32 {
        let sq: f64 = (0..256)
            .map(|k| {
                let s = k as f64 / 255.0;
                (self.linear(s) - srgb_eotf(s as f32) as f64).powi(2)
            })
            .sum();
        (sq / 256.0).sqrt() as f32
    }
}

/// A curve's ln h tabulated on 4,097 stored values, to invert by a binary search.
pub(super) struct Inverse {
    logs: Vec<f64>,
}

impl Inverse {
    pub(super) const STEPS: usize = 4096;

    pub(super) fn of(curve: &Curve) -> Inverse {
        Inverse {
            logs: (0..=Self::STEPS)
                .map(|k| curve.log((k as f64 / Self::STEPS as f64).max(1e-5)))
                .collect(),
        }
    }

    /// The stored value whose ln h is `log` (h is increasing).
    pub(super) fn stored(&self, log: f64) -> f64 {
        let t = &self.logs;
        let i = t.partition_point(|&y| y < log).clamp(1, t.len() - 1);
        let (a, b) = (t[i - 1], t[i]);
        let f = if b > a {
            ((log - a) / (b - a)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        ((i - 1) as f64 + f) / Self::STEPS as f64
    }
}

impl Curve {
    /// Makes h increasing: each segment of ln sRGB⁻¹ + d keeps a positive slope.
    pub(super) fn monotone(&mut self) {
        for k in 1..=KNOTS {
            let (s0, s1) = (Self::knot(k - 1), Self::knot(k));
            let rise = Self::log_srgb(s1) - Self::log_srgb(s0);
            let least = self.d[k - 1] - rise + 1e-3;
            if k > 1 && self.d[k] < least {
                self.d[k] = least;
            }
        }
    }
}
