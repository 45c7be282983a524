//! Baked shadings on disk: one compact binary file per view and a manifest written last.
//!
//! Layout: `DIR/manifest.json` and `DIR/<split>/{k:03}.fsh`. A file is written to a temporary
//! sibling and renamed; the manifest (inputs fingerprint, settings, sample counts, timings) is
//! written only after every view file, so a stage interrupted at any moment leaves either no
//! manifest (the stage is redone) or a complete one. A re-run with the same inputs and settings
//! reuses the files; any change invalidates them.
//!
//! The `.fsh` format of a view's file, dense or holding the valid pixels only: [`crate::fsh`].
use crate::bake::BakeConfig;
use fipt_core::fsutil::{hash_files, read_json, write_bytes_atomic, write_json_atomic};
use fipt_core::shading::{PixelDraw, Shard, ViewShadings};
use fipt_core::{CoreError, Result};
use serde::{Deserialize, Serialize};

use crate::fsh::{damaged, Layout, HEAD};
pub use crate::fsh::{decode, encode, ViewFile};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Version of the manifest (and of the first `.fsh` files; the files' own versions are
/// [`crate::fsh`]'s).
pub const FORMAT_VERSION: u32 = 1;

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
            let mut head = [0u8; HEAD];
            let len = std::fs::File::open(&p)
                .and_then(|mut f| {
                    let read = f.read(&mut head)?;
                    Ok((read, f.metadata()?.len()))
                })
                .map_err(|e| CoreError::io(&p, e))?;
            let (read, len) = len;
            let expected = Layout::of(&head[..read], &p)?.len;
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
