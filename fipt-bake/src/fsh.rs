//! The `.fsh` file of one view's shadings (little endian): magic `FIPTSHD\0`, u32 version,
//! u32 width, u32 height, u32 levels, [sparse versions: u32 stored pixels], f32 × levels,
//! u8 × pixels (valid), then for each stored pixel in order: f32 × 3 (Ld); [versions 2 and 4:
//! f32 × 3 × 2 (Ld1, Ld2: the diffuse shading's σ polynomial)]; f32 × 3 × levels (Ls0); the
//! same for Ls1 (each array whole before the next).
//!
//! Dense files (versions 1 and 2) store every pixel. Sparse files (3 and 4) store the valid
//! pixels only, the others reading back as zeros: they are written whenever that gives back
//! exactly the same shadings (every invalid pixel all zeros, as a bake's misses and the pixels
//! a drawn bake leaves out are) and stores fewer pixels. A drawn bake that shades 13 % of its
//! pixels then stores about 14 % of the bytes (one byte per pixel for the valid flags).
//! Versions without the polynomial are written for FIPT's model, with it for `principled`.
use fipt_core::shading::{ViewShadings, NUM_LEVELS};
use fipt_core::{CoreError, Result};
use glam::Vec3;
use std::path::Path;

const MAGIC: &[u8; 8] = b"FIPTSHD\0";
const DENSE: u32 = 1;
const DENSE_POLY: u32 = 2;
const SPARSE: u32 = 3;
const SPARSE_POLY: u32 = 4;

/// Bytes enough to read any file's layout ([`Layout::of`]).
pub(crate) const HEAD: usize = 28;

/// Where a file's parts are, from its header.
pub(crate) struct Layout {
    pub width: usize,
    pub height: usize,
    poly: bool,
    sparse: bool,
    /// Pixels of the view.
    n: usize,
    /// Pixels stored (n for a dense file).
    stored: usize,
    levels_at: usize,
    valid_at: usize,
    ld_at: usize,
    poly_at: usize,
    ls0_at: usize,
    ls1_at: usize,
    /// The file's length in bytes.
    pub len: usize,
}

impl Layout {
    /// The layout a header gives; `bytes` needs only the first [`HEAD`] (a dense file's 24).
    pub(crate) fn of(bytes: &[u8], path: &Path) -> Result<Self> {
        if bytes.len() < 24 || &bytes[..8] != MAGIC {
            return Err(damaged(path, "wrong magic"));
        }
        let u = |i: usize| u32::from_le_bytes(bytes[8 + 4 * i..12 + 4 * i].try_into().unwrap());
        let (ver, w, h, nl) = (u(0), u(1) as usize, u(2) as usize, u(3) as usize);
        if !(DENSE..=SPARSE_POLY).contains(&ver) || nl != NUM_LEVELS {
            return Err(damaged(path, &format!("version {ver} with {nl} levels")));
        }
        let (poly, sparse) = (ver == DENSE_POLY || ver == SPARSE_POLY, ver >= SPARSE);
        if sparse && bytes.len() < HEAD {
            return Err(damaged(path, "a header cut short"));
        }
        let n = w.checked_mul(h);
        let stored = if sparse { Some(u(4) as usize) } else { n };
        // Checked: a corrupt size must not wrap around to a plausible length.
        let at = |stored: usize, n: usize| -> Option<[usize; 6]> {
            let levels_at = if sparse { 28 } else { 24 };
            let valid_at = levels_at + 4 * nl;
            let ld_at = valid_at.checked_add(n)?;
            let poly_at = ld_at.checked_add(stored.checked_mul(12)?)?;
            let ls0_at = poly_at.checked_add(if poly { stored.checked_mul(24)? } else { 0 })?;
            let ls1_at = ls0_at.checked_add(stored.checked_mul(12 * nl)?)?;
            let len = ls1_at.checked_add(stored.checked_mul(12 * nl)?)?;
            Some([valid_at, ld_at, poly_at, ls0_at, ls1_at, len])
        };
        let parts = (n.zip(stored)).filter(|(n, s)| s <= n);
        let Some(([valid_at, ld_at, poly_at, ls0_at, ls1_at, len], (n, stored))) =
            parts.and_then(|(n, s)| Some((at(s, n)?, (n, s))))
        else {
            return Err(damaged(path, &format!("a {w}x{h} header")));
        };
        Ok(Layout {
            width: w,
            height: h,
            poly,
            sparse,
            n,
            stored,
            levels_at: valid_at - 4 * nl,
            valid_at,
            ld_at,
            poly_at,
            ls0_at,
            ls1_at,
            len,
        })
    }
}

/// A pixel with nothing stored: all its shadings are zero (+0.0).
fn zero(s: &ViewShadings, i: usize) -> bool {
    let z = |v: &Vec3| v.to_array().iter().all(|c| c.to_bits() == 0);
    z(&s.ld[i])
        && s.ld_poly.get(i).is_none_or(|p| p.iter().all(z))
        && s.ls0[i].iter().all(z)
        && s.ls1[i].iter().all(z)
}

/// Encodes one view's shadings: sparse when that reads back the same and stores fewer
/// pixels, dense otherwise.
pub fn encode(s: &ViewShadings) -> Vec<u8> {
    let n = s.width * s.height;
    let poly = !s.ld_poly.is_empty();
    let valid: Vec<usize> = (0..n).filter(|&i| s.valid[i]).collect();
    let sparse = valid.len() < n && (0..n).all(|i| s.valid[i] || zero(s, i));
    let stored: Vec<usize> = if sparse { valid } else { (0..n).collect() };
    let per = 1 + 2 * poly as usize + 2 * NUM_LEVELS;
    let mut out = Vec::with_capacity(HEAD + NUM_LEVELS * 4 + n + stored.len() * 12 * per);
    out.extend_from_slice(MAGIC);
    let version = match (sparse, poly) {
        (false, false) => DENSE,
        (false, true) => DENSE_POLY,
        (true, false) => SPARSE,
        (true, true) => SPARSE_POLY,
    };
    let mut head = vec![version, s.width as u32, s.height as u32, NUM_LEVELS as u32];
    if sparse {
        head.push(stored.len() as u32);
    }
    for v in head {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for l in s.levels {
        out.extend_from_slice(&l.to_le_bytes());
    }
    out.extend(s.valid.iter().map(|&v| v as u8));
    let mut put = |v: &Vec3| {
        for c in v.to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    };
    stored.iter().for_each(|&i| put(&s.ld[i]));
    if poly {
        stored
            .iter()
            .for_each(|&i| s.ld_poly[i].iter().for_each(&mut put));
    }
    stored
        .iter()
        .for_each(|&i| s.ls0[i].iter().for_each(&mut put));
    stored
        .iter()
        .for_each(|&i| s.ls1[i].iter().for_each(&mut put));
    out
}

pub(crate) fn damaged(path: &Path, m: &str) -> CoreError {
    CoreError::invalid(
        path,
        format!("not a valid shading file: {m} (delete it to re-bake)"),
    )
}

/// One view's stored shadings as read from its file, checked; pixels are decoded on demand.
pub struct ViewFile<'b> {
    bytes: &'b [u8],
    layout: Layout,
    levels: [f32; NUM_LEVELS],
    /// Per pixel, its place among the stored ones (`u32::MAX`: none); empty for a dense file.
    rank: Vec<u32>,
}

impl<'b> ViewFile<'b> {
    pub(crate) fn new(bytes: &'b [u8], path: &Path) -> Result<Self> {
        let layout = Layout::of(bytes, path)?;
        if bytes.len() != layout.len {
            return Err(damaged(
                path,
                &format!(
                    "{} bytes, expected {} (truncated?)",
                    bytes.len(),
                    layout.len
                ),
            ));
        }
        let mut levels = [0.0; NUM_LEVELS];
        for (l, c) in levels
            .iter_mut()
            .zip(bytes[layout.levels_at..].chunks_exact(4))
        {
            *l = f32::from_le_bytes(c.try_into().unwrap());
        }
        let mut rank = vec![];
        if layout.sparse {
            let flags = &bytes[layout.valid_at..layout.valid_at + layout.n];
            let mut next = 0u32;
            rank = (flags.iter())
                .map(|&v| {
                    if v == 0 {
                        return u32::MAX;
                    }
                    next += 1;
                    next - 1
                })
                .collect();
            if next as usize != layout.stored {
                return Err(damaged(
                    path,
                    &format!("{next} valid pixels, {} stored", layout.stored),
                ));
            }
        }
        Ok(ViewFile {
            bytes,
            layout,
            levels,
            rank,
        })
    }

    /// (width, height) of the view.
    pub fn size(&self) -> (usize, usize) {
        (self.layout.width, self.layout.height)
    }

    /// Whether each pixel's shadings are valid.
    pub fn valid(&self) -> Vec<bool> {
        let at = self.layout.valid_at;
        (self.bytes[at..at + self.layout.n].iter())
            .map(|&b| b != 0)
            .collect()
    }

    /// The pixels `idx` alone, as [`ViewShadings::select`] gives them from the decoded view.
    pub fn select(&self, idx: &[u32]) -> ViewShadings {
        let (b, l) = (self.bytes, &self.layout);
        let f = |off: usize| f32::from_le_bytes(b[off..off + 4].try_into().unwrap());
        let vec3 = |off: usize| Vec3::new(f(off), f(off + 4), f(off + 8));
        // Each pixel's place among the stored ones; None: nothing stored (zeros).
        let place = |i: usize| match self.rank.get(i) {
            None => Some(i),
            Some(&u32::MAX) => None,
            Some(&r) => Some(r as usize),
        };
        let px: Vec<(usize, Option<usize>)> = idx
            .iter()
            .map(|&i| (i as usize, place(i as usize)))
            .collect();
        let levels = |at: usize, r: Option<usize>| -> [Vec3; NUM_LEVELS] {
            std::array::from_fn(|k| r.map_or(Vec3::ZERO, |r| vec3(at + 12 * (NUM_LEVELS * r + k))))
        };
        ViewShadings {
            width: idx.len(),
            height: 1,
            levels: self.levels,
            ld: (px.iter())
                .map(|&(_, r)| r.map_or(Vec3::ZERO, |r| vec3(l.ld_at + 12 * r)))
                .collect(),
            ld_poly: if l.poly {
                (px.iter())
                    .map(|&(_, r)| {
                        r.map_or([Vec3::ZERO; 2], |r| {
                            [vec3(l.poly_at + 24 * r), vec3(l.poly_at + 24 * r + 12)]
                        })
                    })
                    .collect()
            } else {
                vec![]
            },
            ls0: px.iter().map(|&(_, r)| levels(l.ls0_at, r)).collect(),
            ls1: px.iter().map(|&(_, r)| levels(l.ls1_at, r)).collect(),
            valid: px.iter().map(|&(i, _)| b[l.valid_at + i] != 0).collect(),
        }
    }

    /// The whole view.
    pub fn decode(&self) -> ViewShadings {
        let n = self.layout.n as u32;
        let all: Vec<u32> = (0..n).collect();
        let mut s = self.select(&all);
        (s.width, s.height) = self.size();
        s
    }
}

/// Decodes one view's shadings; `path` names the file in errors.
pub fn decode(bytes: &[u8], path: &Path) -> Result<ViewShadings> {
    Ok(ViewFile::new(bytes, path)?.decode())
}

#[cfg(test)]
mod tests {
    use super::*;
    use fipt_core::shading::DEFAULT_LEVELS;

    #[test]
    fn binary_round_trip_is_exact_and_truncation_is_named() {
        let mut s = ViewShadings::zeros(5, 3, DEFAULT_LEVELS);
        for i in 0..15 {
            s.valid[i] = i % 3 != 0;
            s.ld[i] = Vec3::new(i as f32, 1e-6, 1e5);
            for l in 0..NUM_LEVELS {
                s.ls0[i][l] = Vec3::splat((i * l) as f32 * 0.25);
                s.ls1[i][l] = Vec3::new(l as f32, -0.0, 3.5);
            }
        }
        let b = encode(&s);
        assert_eq!(decode(&b, Path::new("x.fsh")).unwrap(), s);
        // With the diffuse σ polynomial (version 2).
        let mut p = s.clone();
        p.ld_poly = (0..15)
            .map(|i| [Vec3::splat(i as f32), Vec3::new(-1.0, 2e-7, 3e4)])
            .collect();
        let bp = encode(&p);
        assert_eq!(bp.len(), b.len() + 15 * 24);
        assert_eq!(decode(&bp, Path::new("x.fsh")).unwrap(), p);
        // Pixels selected from the file equal the same pixels of the decoded view.
        for (bytes, view) in [(&b, &s), (&bp, &p)] {
            let file = ViewFile::new(bytes, Path::new("x.fsh")).unwrap();
            assert_eq!(file.valid(), view.valid);
            assert_eq!(file.size(), (5, 3));
            let idx = [14, 0, 7, 7, 3];
            assert_eq!(file.select(&idx), view.select(&idx));
            assert_eq!(file.select(&[]), view.select(&[]));
        }
        assert!(ViewFile::new(&b[..b.len() - 1], Path::new("x.fsh")).is_err());
        let err = decode(&b[..b.len() - 4], Path::new("v/003.fsh"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("v/003.fsh") && err.contains("truncated"),
            "{err}"
        );
        // Invalid pixels that hold values: stored dense, to read back the same.
        assert_eq!(
            b.len(),
            24 + 4 * NUM_LEVELS + 15 * (1 + 12 * (1 + 2 * NUM_LEVELS))
        );
    }

    /// Invalid pixels that are all zeros (misses, pixels a drawn bake leaves out) are not
    /// stored: the file is smaller, reads back the same view, whole or selected, and its
    /// length is checked from the header.
    #[test]
    fn a_sparse_file_stores_the_valid_pixels_only_and_reads_back_the_same() {
        let mut s = ViewShadings::zeros(6, 4, DEFAULT_LEVELS);
        for i in (0..24).filter(|i| i % 5 == 2) {
            s.valid[i] = true;
            s.ld[i] = Vec3::new(i as f32, 1e-6, 1e5);
            for l in 0..NUM_LEVELS {
                s.ls0[i][l] = Vec3::splat((i * l) as f32 * 0.25 + 1.0);
                s.ls1[i][l] = Vec3::new(l as f32, -0.0, 3.5);
            }
        }
        let mut p = s.clone();
        p.ld_poly = (0..24)
            .map(|i| match p.valid[i] {
                true => [Vec3::splat(i as f32), Vec3::new(-1.0, 2e-7, 3e4)],
                false => [Vec3::ZERO; 2],
            })
            .collect();
        let stored = 5;
        for (view, per) in [(&s, 1 + 2 * NUM_LEVELS), (&p, 3 + 2 * NUM_LEVELS)] {
            let b = encode(view);
            assert_eq!(b.len(), 28 + 4 * NUM_LEVELS + 24 + stored * 12 * per);
            assert_eq!(&decode(&b, Path::new("x.fsh")).unwrap(), view);
            let file = ViewFile::new(&b, Path::new("x.fsh")).unwrap();
            assert_eq!(file.valid(), view.valid);
            let idx = [22, 0, 7, 7, 3, 12];
            assert_eq!(file.select(&idx), view.select(&idx));
            assert!(ViewFile::new(&b[..b.len() - 12], Path::new("x.fsh")).is_err());
            assert_eq!(
                Layout::of(&b[..HEAD], Path::new("x.fsh")).unwrap().len,
                b.len()
            );
            // A file whose flags disagree with its count is refused.
            let mut bad = b.clone();
            bad[28 + 4 * NUM_LEVELS] = 1;
            let err = ViewFile::new(&bad, Path::new("x.fsh"))
                .err()
                .unwrap()
                .to_string();
            assert!(err.contains("6 valid pixels, 5 stored"), "{err}");
        }
        // Every pixel valid: dense, as before.
        let mut all = s.clone();
        all.valid = vec![true; 24];
        assert_eq!(
            encode(&all).len(),
            24 + 4 * NUM_LEVELS + 24 * (1 + 12 * (1 + 2 * NUM_LEVELS))
        );
        assert_eq!(decode(&encode(&all), Path::new("x.fsh")).unwrap(), all);
    }
}
