//! Baked shadings on disk: one compact binary file per view and a manifest written last.
//!
//! Layout: `DIR/manifest.json` and `DIR/<split>/{k:03}.fsh`. A file is written to a temporary
//! sibling and renamed; the manifest (inputs fingerprint, settings, sample counts, timings) is
//! written only after every view file, so a stage interrupted at any moment leaves either no
//! manifest (the stage is redone) or a complete one. A re-run with the same inputs and settings
//! reuses the files; any change invalidates them.
//!
//! `.fsh` format (little endian): magic `FIPTSHD\0`, u32 version, u32 width, u32 height,
//! u32 levels, f32 × levels, u8 × pixels (valid), f32 × 3 × pixels (Ld),
//! [version 2 only: f32 × 3 × 2 × pixels (Ld1, Ld2: the diffuse shading's σ polynomial)],
//! f32 × 3 × levels × pixels (Ls0), the same for Ls1. Version 1 is written when the shadings
//! have no σ polynomial (FIPT's model), version 2 when they do (`principled`).
use crate::bake::BakeConfig;
use fipt_core::fsutil::{hash_files, read_json, write_bytes_atomic, write_json_atomic};
use fipt_core::shading::{PixelDraw, Shard, ViewShadings, NUM_LEVELS};
use fipt_core::{CoreError, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"FIPTSHD\0";
/// Version of the `.fsh` format (without the diffuse σ polynomial) and of the manifest.
pub const FORMAT_VERSION: u32 = 1;
/// Version of `.fsh` files that carry the diffuse σ polynomial.
const FORMAT_VERSION_POLY: u32 = 2;

/// What a stored bake was computed from and how.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BakeManifest {
    pub version: u32,
    pub baker: String,
    /// Fingerprint of the mesh, cameras and training images.
    pub inputs_hash: String,
    /// The settings exactly as written: compared as JSON, so a setting added in a later
    /// version of fipt (absent here) invalidates the bake instead of taking its default.
    pub config: serde_json::Value,
    pub split: String,
    pub views: usize,
    pub width: usize,
    pub height: usize,
    /// The baker's report (`ShadingBaker::bake`); null for refinements.
    #[serde(default)]
    pub stats: serde_json::Value,
    pub seconds_total: f64,
    /// Each view file's content hash (FNV-1a 64, by view index), recorded when the stage is
    /// finished and checked before it is reused: a file changed since is computed again.
    /// Empty in manifests written before it existed (then not checked).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub hashes: BTreeMap<usize, String>,
    /// The hit pixels computed: every one (absent), or the share a run drew for what it reads
    /// (`fipt_core::shading::PixelDraw`); the others read as misses.
    #[serde(default, skip_serializing_if = "PixelDraw::is_all")]
    pub pixels: PixelDraw,
}

/// Path of view `k`'s file.
pub fn view_path(dir: &Path, split: &str, k: usize) -> PathBuf {
    dir.join(split).join(format!("{k:03}.fsh"))
}

/// Encodes one view's shadings.
pub fn encode(s: &ViewShadings) -> Vec<u8> {
    let n = s.width * s.height;
    let poly = !s.ld_poly.is_empty();
    let mut out = Vec::with_capacity(
        28 + NUM_LEVELS * 4 + n * (1 + 12 * (1 + 2 * poly as usize + 2 * NUM_LEVELS)),
    );
    out.extend_from_slice(MAGIC);
    for v in [
        if poly {
            FORMAT_VERSION_POLY
        } else {
            FORMAT_VERSION
        },
        s.width as u32,
        s.height as u32,
        NUM_LEVELS as u32,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for l in s.levels {
        out.extend_from_slice(&l.to_le_bytes());
    }
    out.extend(s.valid.iter().map(|&v| v as u8));
    let mut put = |v: Vec3| {
        for c in v.to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    };
    s.ld.iter().for_each(|&v| put(v));
    s.ld_poly.iter().flatten().for_each(|&v| put(v));
    s.ls0.iter().flatten().for_each(|&v| put(v));
    s.ls1.iter().flatten().for_each(|&v| put(v));
    out
}

/// What a `.fsh` header says: (width, height, whether the σ polynomial is stored, pixels,
/// the file's length in bytes). `bytes` needs only the first 24.
fn header(bytes: &[u8], path: &Path) -> Result<(usize, usize, bool, usize, usize)> {
    if bytes.len() < 24 || &bytes[..8] != MAGIC {
        return Err(damaged(path, "wrong magic"));
    }
    let u = |i: usize| u32::from_le_bytes(bytes[8 + 4 * i..12 + 4 * i].try_into().unwrap());
    let (ver, w, h, nl) = (u(0), u(1) as usize, u(2) as usize, u(3) as usize);
    if !(ver == FORMAT_VERSION || ver == FORMAT_VERSION_POLY) || nl != NUM_LEVELS {
        return Err(damaged(path, &format!("version {ver} with {nl} levels")));
    }
    let poly = ver == FORMAT_VERSION_POLY;
    // Checked: a corrupt size must not wrap around to a plausible length.
    let sizes = w.checked_mul(h).and_then(|n| {
        let per = 12usize.checked_mul(1 + 2 * poly as usize + 2 * nl)?;
        Some((
            n,
            (24 + 4 * nl)
                .checked_add(n)?
                .checked_add(n.checked_mul(per)?)?,
        ))
    });
    let Some((n, expected)) = sizes else {
        return Err(damaged(path, &format!("a {w}x{h} header")));
    };
    Ok((w, h, poly, n, expected))
}

fn damaged(path: &Path, m: &str) -> CoreError {
    CoreError::invalid(
        path,
        format!("not a valid shading file: {m} (delete it to re-bake)"),
    )
}

/// One view's stored shadings as read from its file, checked; pixels are decoded on demand.
pub struct ViewFile<'b> {
    bytes: &'b [u8],
    width: usize,
    height: usize,
    levels: [f32; NUM_LEVELS],
    poly: bool,
    n: usize,
}

impl<'b> ViewFile<'b> {
    fn new(bytes: &'b [u8], path: &Path) -> Result<Self> {
        let (width, height, poly, n, expected) = header(bytes, path)?;
        if bytes.len() != expected {
            return Err(damaged(
                path,
                &format!("{} bytes, expected {expected} (truncated?)", bytes.len()),
            ));
        }
        let mut levels = [0.0; NUM_LEVELS];
        for (l, c) in levels.iter_mut().zip(bytes[24..].chunks_exact(4)) {
            *l = f32::from_le_bytes(c.try_into().unwrap());
        }
        Ok(ViewFile {
            bytes,
            width,
            height,
            levels,
            poly,
            n,
        })
    }

    /// (width, height) of the view.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Whether each pixel's shadings are valid.
    pub fn valid(&self) -> Vec<bool> {
        let off = 24 + 4 * NUM_LEVELS;
        self.bytes[off..off + self.n]
            .iter()
            .map(|&b| b != 0)
            .collect()
    }

    /// The pixels `idx` alone, as [`ViewShadings::select`] gives them from the decoded view.
    pub fn select(&self, idx: &[u32]) -> ViewShadings {
        let b = self.bytes;
        let f = |off: usize| f32::from_le_bytes(b[off..off + 4].try_into().unwrap());
        let vec3 = |off: usize| Vec3::new(f(off), f(off + 4), f(off + 8));
        let valid_at = 24 + 4 * NUM_LEVELS;
        let ld_at = valid_at + self.n;
        let poly_at = ld_at + 12 * self.n;
        let ls0_at = poly_at + if self.poly { 24 * self.n } else { 0 };
        let ls1_at = ls0_at + 12 * NUM_LEVELS * self.n;
        let px = idx.iter().map(|&i| i as usize);
        let levels = |at: usize, i: usize| -> [Vec3; NUM_LEVELS] {
            std::array::from_fn(|l| vec3(at + 12 * (NUM_LEVELS * i + l)))
        };
        ViewShadings {
            width: idx.len(),
            height: 1,
            levels: self.levels,
            ld: px.clone().map(|i| vec3(ld_at + 12 * i)).collect(),
            ld_poly: if self.poly {
                px.clone()
                    .map(|i| [vec3(poly_at + 24 * i), vec3(poly_at + 24 * i + 12)])
                    .collect()
            } else {
                vec![]
            },
            ls0: px.clone().map(|i| levels(ls0_at, i)).collect(),
            ls1: px.clone().map(|i| levels(ls1_at, i)).collect(),
            valid: px.map(|i| b[valid_at + i] != 0).collect(),
        }
    }
}

/// Decodes one view's shadings; `path` names the file in errors.
pub fn decode(bytes: &[u8], path: &Path) -> Result<ViewShadings> {
    let (w, h, poly, n, expected) = header(bytes, path)?;
    if bytes.len() != expected {
        return Err(damaged(
            path,
            &format!("{} bytes, expected {expected} (truncated?)", bytes.len()),
        ));
    }
    let f = |off: usize| f32::from_le_bytes(bytes[off..off + 4].try_into().unwrap());
    let mut off = 24;
    let mut levels = [0.0; NUM_LEVELS];
    for l in levels.iter_mut() {
        *l = f(off);
        off += 4;
    }
    let valid = bytes[off..off + n].iter().map(|&b| b != 0).collect();
    off += n;
    let vec3 = |off: &mut usize| {
        let v = Vec3::new(f(*off), f(*off + 4), f(*off + 8));
        *off += 12;
        v
    };
    let ld = (0..n).map(|_| vec3(&mut off)).collect();
    let ld_poly = if poly {
        (0..n)
            .map(|_| std::array::from_fn(|_| vec3(&mut off)))
            .collect()
    } else {
        Vec::new()
    };
    let ls0 = (0..n)
        .map(|_| std::array::from_fn(|_| vec3(&mut off)))
        .collect();
    let ls1 = (0..n)
        .map(|_| std::array::from_fn(|_| vec3(&mut off)))
        .collect();
    Ok(ViewShadings {
        width: w,
        height: h,
        levels,
        ld,
        ld_poly,
        ls0,
        ls1,
        valid,
    })
}

/// Writes every view's file, then the manifest.
pub fn save(dir: &Path, manifest: &BakeManifest, shadings: &[ViewShadings]) -> Result<()> {
    begin(dir, Shard::ALL)?;
    for (k, s) in shadings.iter().enumerate() {
        write_view(dir, &manifest.split, k, s)?;
    }
    finish(dir, manifest, Shard::ALL)
}

/// Starts writing a stage's views into `dir` (`shard`'s, or all): removes the manifests that
/// would vouch for files about to change (the stage's, and the shard's own).
pub fn begin(dir: &Path, shard: Shard) -> Result<()> {
    let mut stale = vec![dir.join("manifest.json")];
    if shard.is_all() {
        // The whole stage is computed again: every shard set is stale.
        stale.extend(shard_manifests(dir));
    } else {
        stale.push(shard_manifest_path(dir, shard));
    }
    for p in stale {
        if p.exists() {
            std::fs::remove_file(&p).map_err(|e| CoreError::io(&p, e))?;
        }
    }
    Ok(())
}

/// Writes view `k`'s file (temporary file, then rename).
pub fn write_view(dir: &Path, split: &str, k: usize, s: &ViewShadings) -> Result<()> {
    write_bytes_atomic(&view_path(dir, split, k), &encode(s))
}

/// Ends a stage's writing: its manifest, or `shard`'s (`manifest.views` is the stage's view
/// count), once every view file is written.
pub fn finish(dir: &Path, manifest: &BakeManifest, shard: Shard) -> Result<()> {
    let path = if shard.is_all() {
        dir.join("manifest.json")
    } else {
        shard_manifest_path(dir, shard)
    };
    let mut m = manifest.clone();
    m.hashes = (0..m.views)
        .filter(|k| shard.contains(*k))
        .map(|k| Ok((k, hash_files(&[view_path(dir, &m.split, k)])?)))
        .collect::<Result<_>>()?;
    write_json_atomic(&path, &m)
}

/// The first view file of `m` in `dir` whose content no longer has its recorded hash.
fn changed_view(dir: &Path, m: &BakeManifest) -> Result<Option<String>> {
    for (k, h) in &m.hashes {
        let p = view_path(dir, &m.split, *k);
        let now = hash_files(&[p.clone()])?;
        if &now != h {
            return Ok(Some(format!(
                "warning: {} was changed after it was written (content hash {now}, recorded {h}): computing the stage again",
                p.display()
            )));
        }
    }
    Ok(None)
}

/// Shadings one view at a time, whether held in memory or stored on disk: what a consumer
/// that reads the views in turn takes.
pub trait ShadingViews {
    /// The number of views.
    fn count(&self) -> usize;
    /// View `k`'s shadings.
    fn get(&self, k: usize) -> Result<std::borrow::Cow<'_, ViewShadings>>;
}

impl ShadingViews for Vec<ViewShadings> {
    fn count(&self) -> usize {
        self.len()
    }
    fn get(&self, k: usize) -> Result<std::borrow::Cow<'_, ViewShadings>> {
        Ok(std::borrow::Cow::Borrowed(&self[k]))
    }
}

impl ShadingViews for StoredShadings {
    fn count(&self) -> usize {
        self.views
    }
    fn get(&self, k: usize) -> Result<std::borrow::Cow<'_, ViewShadings>> {
        self.view(k).map(std::borrow::Cow::Owned)
    }
}

/// A finished stage's shadings on disk, read one view at a time, so that a consumer need not
/// hold every view at once.
#[derive(Clone, Debug)]
pub struct StoredShadings {
    pub dir: PathBuf,
    pub split: String,
    pub views: usize,
    /// The hit pixels the stage computed; the others read as misses.
    pub pixels: PixelDraw,
}

impl StoredShadings {
    /// The shadings of the finished stage in `dir` that `manifest` describes.
    pub fn of(dir: &Path, manifest: &BakeManifest) -> Self {
        StoredShadings {
            dir: dir.to_path_buf(),
            split: manifest.split.clone(),
            views: manifest.views,
            pixels: manifest.pixels,
        }
    }

    /// View `k`'s shadings.
    pub fn view(&self, k: usize) -> Result<ViewShadings> {
        let p = view_path(&self.dir, &self.split, k);
        let bytes = std::fs::read(&p).map_err(|e| CoreError::io(&p, e))?;
        decode(&bytes, &p)
    }

    /// View `k`'s file read into `buf` (its memory reused from view to view), to select
    /// pixels from without decoding the whole view ([`ViewFile`]).
    pub fn read_view<'b>(&self, k: usize, buf: &'b mut Vec<u8>) -> Result<ViewFile<'b>> {
        use std::io::Read;
        let p = view_path(&self.dir, &self.split, k);
        buf.clear();
        std::fs::File::open(&p)
            .and_then(|mut f| f.read_to_end(buf))
            .map_err(|e| CoreError::io(&p, e))?;
        ViewFile::new(buf, &p)
    }

    /// Every view's shadings, in order.
    pub fn load_all(&self) -> Result<Vec<ViewShadings>> {
        (0..self.views).map(|k| self.view(k)).collect()
    }

    /// Checks that every view's file is present and as long as its header says, without
    /// reading it (a damaged or truncated file is found before any work relies on it).
    pub fn check(&self) -> Result<()> {
        use std::io::Read;
        for k in 0..self.views {
            let p = view_path(&self.dir, &self.split, k);
            let mut head = [0u8; 24];
            let len = std::fs::File::open(&p)
                .and_then(|mut f| {
                    f.read_exact(&mut head)?;
                    Ok(f.metadata()?.len())
                })
                .map_err(|e| CoreError::io(&p, e))?;
            let expected = header(&head, &p)?.4;
            if len != expected as u64 {
                return Err(damaged(
                    &p,
                    &format!("{len} bytes, expected {expected} (truncated?)"),
                ));
            }
        }
        Ok(())
    }
}

/// Why a stored bake cannot be reused (None when it can).
pub fn mismatch(
    m: &BakeManifest,
    inputs_hash: &str,
    config: &serde_json::Value,
    baker: &str,
) -> Option<String> {
    if m.version != FORMAT_VERSION {
        return Some(format!(
            "format version {} (this fipt writes {FORMAT_VERSION})",
            m.version
        ));
    }
    if m.inputs_hash != inputs_hash {
        return Some("the scene's mesh, cameras or images changed".into());
    }
    if m.baker != baker {
        return Some(format!("baked by {} (now {baker})", m.baker));
    }
    // Same keys (a key added by a later fipt is a change) and equal typed values (JSON numbers
    // of f32 settings do not compare bit for bit after a text round trip).
    // Settings of another baker (a plug-in's) compare as JSON.
    let keys = |v: &serde_json::Value| v.as_object().map(|o| o.keys().cloned().collect::<Vec<_>>());
    let same_keys = keys(config) == keys(&m.config);
    let typed = |v: &serde_json::Value| serde_json::from_value::<BakeConfig>(v.clone()).ok();
    let same = match (typed(&m.config), typed(config)) {
        (Some(a), Some(b)) => a == b,
        _ => m.config == *config,
    };
    if !same_keys || !same {
        return Some("the bake settings changed".into());
    }
    None
}

/// A fingerprint of what a stored bake holds: its baker, inputs and settings (bakes are
/// deterministic, so equal fingerprints mean equal shadings). Later stages key on it.
pub fn fingerprint(m: &BakeManifest) -> String {
    let settings = fipt_core::fsutil::hash_json(&m.config);
    let key = format!("{}|{}|{}|{settings}", m.version, m.baker, m.inputs_hash);
    fipt_core::fsutil::hash_bytes((key + &m.pixels.key_tag()).as_bytes())
}

/// Why a stored result keyed by `key` (see [`load_keyed`]) cannot be reused (None when it can).
pub fn keyed_mismatch(
    m: &BakeManifest,
    inputs_hash: &str,
    baker: &str,
    key: &str,
) -> Option<String> {
    if m.version != FORMAT_VERSION {
        Some(format!("format version {}", m.version))
    } else if m.inputs_hash != inputs_hash {
        Some("the scene's mesh, cameras or images changed".into())
    } else if m.baker != baker {
        Some(format!("made by {} (now {baker})", m.baker))
    } else if m.config.get("key").and_then(|k| k.as_str()) != Some(key) {
        Some("the settings or the upstream results changed".into())
    } else {
        None
    }
}

/// Loads a stored bake made by `baker` from these inputs whose settings JSON has `key` at
/// `config.key` (for stages keyed by a fingerprint of their settings and upstream results).
/// `Ok(Err(reason))` says why not.
pub fn load_keyed(
    dir: &Path,
    inputs_hash: &str,
    baker: &str,
    key: &str,
) -> Result<std::result::Result<(BakeManifest, StoredShadings), String>> {
    load_checked(dir, |m| keyed_mismatch(m, inputs_hash, baker, key))
}

/// Loads a stored bake if it matches the inputs and settings. `Ok(Err(reason))` says why not.
pub fn load_if_current(
    dir: &Path,
    inputs_hash: &str,
    config: &serde_json::Value,
    baker: &str,
) -> Result<std::result::Result<(BakeManifest, StoredShadings), String>> {
    load_checked(dir, |m| mismatch(m, inputs_hash, config, baker))
}

/// Loads a finished bake of these inputs, whatever its settings (the later stages use any
/// bake of the right scene). `Ok(Err(reason))` says why not.
pub fn load_for_inputs(
    dir: &Path,
    inputs_hash: &str,
) -> Result<std::result::Result<(BakeManifest, StoredShadings), String>> {
    load_checked(dir, |m| {
        if m.version != FORMAT_VERSION {
            Some(format!("format version {}", m.version))
        } else if m.inputs_hash != inputs_hash {
            Some("the scene's mesh, cameras or images changed since the bake".into())
        } else {
            None
        }
    })
}

fn load_checked(
    dir: &Path,
    check: impl Fn(&BakeManifest) -> Option<String>,
) -> Result<std::result::Result<(BakeManifest, StoredShadings), String>> {
    let mpath = dir.join("manifest.json");
    if !mpath.is_file() {
        return Ok(Err("no finished bake found".into()));
    }
    let m: BakeManifest = match read_json(&mpath) {
        Ok(m) => m,
        Err(e) => return Ok(Err(format!("unreadable manifest ({e})"))),
    };
    if let Some(why) = check(&m) {
        return Ok(Err(why));
    }
    let stored = StoredShadings::of(dir, &m);
    if let Err(e) = stored.check() {
        return Ok(Err(format!("a stored view is damaged ({e})")));
    }
    match changed_view(dir, &m) {
        Ok(None) => Ok(Ok((m, stored))),
        Ok(Some(why)) => Ok(Err(why)),
        Err(e) => Ok(Err(format!("a stored view cannot be read ({e})"))),
    }
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
    }
}

/// The manifest of one shard of a stage (`manifest.shard-K-of-N.json`).
pub fn shard_manifest_path(dir: &Path, shard: Shard) -> PathBuf {
    dir.join(format!(
        "manifest.shard-{}-of-{}.json",
        shard.index, shard.count
    ))
}

/// Removes every shard manifest in `dir` (a finished stage's are stale).
pub fn clear_shard_manifests(dir: &Path) {
    for p in shard_manifests(dir) {
        let _ = std::fs::remove_file(p);
    }
}

/// Every shard manifest in `dir`, of any count and settings.
fn shard_manifests(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            let name = p.file_name().unwrap_or_default().to_string_lossy();
            name.starts_with("manifest.shard-") && name.ends_with(".json")
        })
        .collect()
}

/// Writes `shard`'s view files, then its shard manifest (`manifest.views` is the stage's
/// view count). A finished manifest of the whole stage is removed first: shards are written
/// only when it did not match.
pub fn save_shard(
    dir: &Path,
    manifest: &BakeManifest,
    shadings: &[ViewShadings],
    shard: Shard,
) -> Result<()> {
    begin(dir, shard)?;
    for (k, s) in shadings
        .iter()
        .enumerate()
        .filter(|(k, _)| shard.contains(*k))
    {
        write_view(dir, &manifest.split, k, s)?;
    }
    finish(dir, manifest, shard)
}

/// What [`merge_shards`] found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ShardState {
    /// No shard manifest of the current settings.
    None,
    /// Shards of `count` (this one's included when it is done) are present, `missing` are not.
    Partial { count: usize, missing: Vec<usize> },
    /// Every shard was present and they were merged into `manifest.json`.
    Merged { count: usize },
}

/// The shard manifests in `dir` that pass `check` (the stage's reuse test), by shard.
fn current_shards(
    dir: &Path,
    check: &impl Fn(&BakeManifest) -> Option<String>,
) -> Vec<(Shard, BakeManifest)> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return vec![];
    };
    let mut out: Vec<(Shard, BakeManifest)> = entries
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().into_string().ok()?;
            let (k, n) = name
                .strip_prefix("manifest.shard-")?
                .strip_suffix(".json")?
                .split_once("-of-")?;
            let shard = Shard::new(k.parse().ok()?, n.parse().ok()?)?;
            // A manifest another process is removing or replacing counts as absent.
            let m: BakeManifest = read_json(&e.path()).ok()?;
            check(&m).is_none().then_some((shard, m))
        })
        .collect();
    out.sort_by_key(|(s, _)| (s.count, s.index));
    out
}

/// Whether `shard`'s part of the stage is stored (its manifest passes `check`).
pub fn shard_done(
    dir: &Path,
    shard: Shard,
    check: &impl Fn(&BakeManifest) -> Option<String>,
) -> bool {
    current_shards(dir, check).iter().any(|(s, _)| *s == shard)
}

/// Merges the shards of a stage once all are present: writes `manifest.json` (the seconds
/// summed, each shard's report under `stats.shards`) and removes the shard manifests. Shards of
/// other settings (failing `check`) are ignored; when shards of several counts are present
/// the largest count is taken. The view files are already in place, so nothing is copied.
pub fn merge_shards(
    dir: &Path,
    check: impl Fn(&BakeManifest) -> Option<String>,
) -> Result<ShardState> {
    let shards = current_shards(dir, &check);
    let complete =
        |n: usize| (0..n).all(|k| shards.iter().any(|(s, _)| s.count == n && s.index == k));
    // A complete set wins over a larger partial one; otherwise the largest count.
    let counts = shards.iter().map(|(s, _)| s.count);
    let Some(count) = counts
        .clone()
        .filter(|&n| complete(n))
        .max()
        .or(counts.max())
    else {
        return Ok(ShardState::None);
    };
    let mine: Vec<&(Shard, BakeManifest)> =
        shards.iter().filter(|(s, _)| s.count == count).collect();
    let missing: Vec<usize> = (0..count)
        .filter(|&k| !mine.iter().any(|(s, _)| s.index == k))
        .collect();
    if !missing.is_empty() {
        return Ok(ShardState::Partial { count, missing });
    }
    let mut merged = mine[0].1.clone();
    merged.seconds_total = mine.iter().map(|(_, m)| m.seconds_total).sum();
    merged.hashes = mine.iter().flat_map(|(_, m)| m.hashes.clone()).collect();
    merged.stats = serde_json::json!({
        "shards": mine.iter().map(|(_, m)| m.stats.clone()).collect::<Vec<_>>(),
    });
    for k in 0..merged.views {
        let p = view_path(dir, &merged.split, k);
        if !p.is_file() {
            return Err(CoreError::invalid(
                &p,
                format!("the shards of {count} are all done but view {k}'s file is missing: run its shard again"),
            ));
        }
    }
    write_json_atomic(&dir.join("manifest.json"), &merged)?;
    // Every shard manifest goes: this set's, and any left by a set of another count or of
    // other settings (stale: the stage is now whole).
    clear_shard_manifests(dir);
    Ok(ShardState::Merged { count })
}
