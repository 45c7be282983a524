//! An LDR view's clipped pixels in the search (`[search] clipped_as_bounds`): lower bounds
//! on the radiance, except beside a clipped light, where they are left out.
use fipt_core::image::Image;

/// A clipped pixel within this many rows and columns of a light's clipped pixel is left out:
/// pose error moves a light's edge by a pixel or two onto the surface around it (a ceiling
/// panel's rim in `studio-mitsuba`'s capture-like copies), and that value says nothing of the
/// surface, not even as a bound. As a bound it let a glossy lobe glow around the panel: the
/// ceiling (σ 1) read 0.84 where it read 0.92 with the rim's pixels counted as exact.
pub(super) const BESIDE_LIGHT: usize = 2;

/// One view's clipped pixels off the lights, from its `left_out` mask (the clipped pixels the
/// material loss leaves out, which are not a light's, and the pixels the view's mask leaves
/// out, which the search drops before these marks are read) and its image.
pub(super) struct ClipMarks {
    /// Left out of the search: beside a light's clipped pixel.
    pub(super) beside_light: Vec<bool>,
    /// Lower bounds: every other clipped pixel (a highlight).
    pub(super) bound: Vec<bool>,
}

/// The marks of one view (one per pixel of `image`): a pixel of `left_out` is beside a light
/// where a pixel within [`BESIDE_LIGHT`] that `left_out` does not hold (a light's, or an
/// unclipped one) has a brightest channel at least as bright as its own: a pixel clips where
/// its brightest channel does, so only a light's clipped pixels have one.
pub(super) fn marks(left_out: &[bool], image: &Image) -> ClipMarks {
    let (w, h) = (image.width, image.height);
    let n = left_out.len().min(w * h);
    let mut beside_light = vec![false; w * h];
    let mut bound = vec![false; w * h];
    let r = BESIDE_LIGHT as isize;
    for i in (0..n).filter(|&i| left_out[i]) {
        let (x, y) = ((i % w) as isize, (i / w) as isize);
        let y0 = image.data[i].max_element();
        let beside = (-r..=r).any(|dy| {
            (-r..=r).any(|dx| {
                let (u, v) = (x + dx, y + dy);
                if u < 0 || v < 0 || u >= w as isize || v >= h as isize {
                    return false;
                }
                let j = v as usize * w + u as usize;
                j < n && !left_out[j] && image.data[j].max_element() >= y0
            })
        });
        beside_light[i] = beside;
        bound[i] = !beside;
    }
    ClipMarks {
        beside_light,
        bound,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn clipped_pixels_beside_a_light_are_left_out_and_the_others_are_bounds() {
        // A row of 8: a light clipped at 0..2 (not left out), clipped surface pixels at
        // 2..4 (left out, one and two pixels from the light) and at 6 (a highlight five
        // pixels away, among darker unclipped ones).
        let mut image = Image::new(8, 1);
        let clip = Vec3::splat(1.0);
        for i in [0, 1, 2, 3, 6] {
            image.data[i] = clip;
        }
        for i in [4, 5, 7] {
            image.data[i] = Vec3::splat(0.5);
        }
        let left_out = [false, false, true, true, false, false, true, false];
        let m = marks(&left_out, &image);
        assert_eq!(
            m.beside_light,
            [false, false, true, true, false, false, false, false]
        );
        assert_eq!(
            m.bound,
            [false, false, false, false, false, false, true, false]
        );
        // Nothing left out: no marks.
        let m = marks(&[false; 8], &image);
        assert!(!m.beside_light.iter().any(|&b| b) && !m.bound.iter().any(|&b| b));
    }
}
