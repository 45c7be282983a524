//! Checks the stage tests share.
use fipt_core::shading::{PixelDraw, ViewShadings};

/// View `k` of a stage computed for `draw` against the same view computed whole: the drawn hit
/// pixels bit for bit the whole one's, the others misses; returns (drawn, left out) hit pixels.
pub fn check_drawn(
    k: usize,
    drawn: &ViewShadings,
    whole: &ViewShadings,
    draw: PixelDraw,
) -> (usize, usize) {
    assert_eq!((drawn.width, drawn.height), (whole.width, whole.height));
    let (mut kept, mut out) = (0, 0);
    for i in 0..whole.valid.len() {
        if !whole.valid[i] {
            assert!(!drawn.valid[i], "view {k} pixel {i}: a miss became a hit");
        } else if draw.keeps(k, i) {
            kept += 1;
            let same = drawn.valid[i]
                && drawn.ld[i] == whole.ld[i]
                && drawn.ls0[i] == whole.ls0[i]
                && drawn.ls1[i] == whole.ls1[i]
                && drawn.ld_poly.get(i) == whole.ld_poly.get(i);
            assert!(
                same,
                "view {k} pixel {i}: drawn, but not as the whole stage has it"
            );
        } else {
            out += 1;
            assert!(
                !drawn.valid[i],
                "view {k} pixel {i}: not drawn, yet computed"
            );
        }
    }
    (kept, out)
}
