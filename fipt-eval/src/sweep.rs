//! The speed/accuracy trade measured (`fipt sweep <scene> --out DIR [--grid sweep.toml]
//! [--quick]`). Every grid point is a `fipt run` of its own process (so its peak memory is its
//! own) into `DIR/<point>/`; finished points are kept (resumable); `DIR/sweep.csv` gets one row
//! per point (settings, wall time per stage, peak memory, the val metrics) and `DIR/sweep.svg`
//! plots kd, σ and re-render against wall time with the Pareto front and the presets marked.
use crate::bail;
use crate::error::{Context, Result};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// `fipt sweep`: a grid of `fipt run`s and their measured trade.
pub struct SweepRequest {
    /// Scene folder.
    pub scene: PathBuf,
    /// Output folder (one sub-folder per point).
    pub out: PathBuf,
    /// The grid (TOML); `None`: [`Grid::default_grid`] of the registered methods.
    pub grid: Option<PathBuf>,
    /// [`Grid::quick`] (when no grid is given).
    pub quick: bool,
    /// The `fipt` binary each point runs as a process of its own (its peak memory its own).
    pub exe: PathBuf,
}

/// What a sweep measured and wrote.
pub struct SweepSummary {
    /// One row per point, in grid order.
    pub rows: Vec<Row>,
    pub csv: PathBuf,
    pub svg: PathBuf,
}

/// The run-config key of the method.
const METHOD_KEY: &str = "pipeline.method";

/// A sweep's grid: each preset, crossed with every combination of the axes' values
/// (`vary = "product"`), or each preset as it is and with one axis changed at a time
/// (`vary = "one_at_a_time"`: a denser grid around the presets at the cost of the sum of the
/// axes' lengths, not their product).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    pub presets: Vec<String>,
    /// Dotted keys of the run config (`train.steps`, `bake.diffuse_samples`) → values.
    #[serde(default)]
    pub axes: BTreeMap<String, Vec<toml::Value>>,
    #[serde(default)]
    pub vary: Vary,
}

/// How a grid combines its axes.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Vary {
    /// Every combination of the axes' values.
    #[default]
    Product,
    /// The preset alone, then each value of each axis with the others at the preset's.
    OneAtATime,
}

impl Grid {
    /// The presets, crossed with `methods` when there is more than one.
    pub fn default_grid(methods: &[&str]) -> Grid {
        let mut axes = BTreeMap::new();
        if methods.len() > 1 {
            axes.insert(
                METHOD_KEY.to_string(),
                methods
                    .iter()
                    .map(|m| toml::Value::String(m.to_string()))
                    .collect(),
            );
        }
        Grid {
            presets: vec!["fast".into(), "balanced".into(), "paper".into()],
            axes,
            vary: Vary::Product,
        }
    }

    /// The names of the points that are a preset as it is (of any method): the plot marks them.
    pub fn preset_points(&self) -> Vec<String> {
        self.points()
            .into_iter()
            .filter(|(_, _, o)| o.iter().all(|(k, _)| k == METHOD_KEY))
            .map(|(n, _, _)| n)
            .collect()
    }

    /// A tiny grid for smoke tests: `fast` at two training lengths.
    pub fn quick() -> Grid {
        let mut axes = BTreeMap::new();
        axes.insert(
            "train.steps".to_string(),
            vec![toml::Value::Integer(300), toml::Value::Integer(900)],
        );
        Grid {
            presets: vec!["fast".into()],
            axes,
            vary: Vary::Product,
        }
    }

    /// The points: (name, preset, overrides).
    pub fn points(&self) -> Vec<(String, String, Vec<(String, toml::Value)>)> {
        let mut combos: Vec<Vec<(String, toml::Value)>> = vec![vec![]];
        for (key, values) in &self.axes {
            let one = |v: &toml::Value| (key.clone(), v.clone());
            combos = match self.vary {
                Vary::Product => combos
                    .into_iter()
                    .flat_map(|c| {
                        values.iter().map(move |v| {
                            let mut c = c.clone();
                            c.push(one(v));
                            c
                        })
                    })
                    .collect(),
                Vary::OneAtATime => {
                    combos.extend(values.iter().map(|v| vec![one(v)]));
                    combos
                }
            };
        }
        let mut out = Vec::new();
        for p in &self.presets {
            for c in &combos {
                let mut name = p.clone();
                for (k, v) in c {
                    name += &format!("_{}={}", k.rsplit('.').next().unwrap_or(k), v);
                }
                let name = name.replace(['"', '/', ' '], "");
                out.push((name, p.clone(), c.clone()));
            }
        }
        out
    }
}

/// A run config (TOML) holding `overrides` at their dotted keys.
fn overrides_toml(overrides: &[(String, toml::Value)]) -> String {
    let mut root = toml::Table::new();
    for (key, v) in overrides {
        let mut t = &mut root;
        let parts: Vec<&str> = key.split('.').collect();
        for p in &parts[..parts.len() - 1] {
            t = t
                .entry(p.to_string())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                .as_table_mut()
                .expect("a table");
        }
        t.insert(parts[parts.len() - 1].to_string(), v.clone());
    }
    toml::to_string(&root).unwrap_or_default()
}

pub use crate::sweep_plot::Row;

fn read_row(dir: &Path, name: &str, preset: &str, settings: &str) -> Option<Row> {
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).ok()?).ok()?;
    if report["status"] != "complete" {
        return None;
    }
    let metrics: serde_json::Value = std::fs::read_to_string(dir.join("metrics.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or(serde_json::Value::Null);
    let split = if metrics["val"].is_object() {
        "val"
    } else {
        "train"
    };
    let m = &metrics[split]["mean"];
    let stages: Vec<(String, f64)> = report["stages"]
        .as_array()
        .map(|a| {
            a.iter()
                .map(|s| {
                    (
                        s["stage"].as_str().unwrap_or("?").to_string(),
                        // A reused stage at the time it took to compute (an earlier run's).
                        (s["computed_seconds"].as_f64())
                            .or(s["seconds"].as_f64())
                            .unwrap_or(0.0),
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    let peak = report["stages"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|s| s["peak_rss_mib"].as_f64())
                .fold(0.0, f64::max)
        })
        .unwrap_or(0.0);
    Some(Row {
        name: name.into(),
        preset: preset.into(),
        settings: settings.into(),
        seconds: (report["seconds_computed_total"].as_f64()).or(report["seconds_total"].as_f64())?,
        stages,
        peak_mib: peak,
        kd: m["kd_psnr"].as_f64(),
        sigma: m["roughness_psnr"].as_f64(),
        render: m["render_psnr"].as_f64(),
        metal_recall: metrics[split]["metallic"]["metal_recall"].as_f64(),
        iou: m["emission_iou"].as_f64(),
    })
}

fn csv(rows: &[Row]) -> String {
    let mut stage_names: Vec<String> = Vec::new();
    for r in rows {
        for (s, _) in &r.stages {
            if !stage_names.contains(s) {
                stage_names.push(s.clone());
            }
        }
    }
    let f = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:.3}"));
    let mut out = String::from(
        "point,preset,settings,seconds,peak_mib,kd_db,sigma_db,render_db,metal_recall,emitter_iou",
    );
    for s in &stage_names {
        out += &format!(",{s}_s");
    }
    out.push('\n');
    for r in rows {
        out += &format!(
            "{},{},\"{}\",{:.1},{:.0},{},{},{},{},{}",
            r.name,
            r.preset,
            r.settings.replace('"', "'").replace('\n', "; "),
            r.seconds,
            r.peak_mib,
            f(r.kd),
            f(r.sigma),
            f(r.render),
            f(r.metal_recall),
            f(r.iou)
        );
        for s in &stage_names {
            // A stage that runs twice (train, search) is summed.
            let t: f64 = r.stages.iter().filter(|x| &x.0 == s).map(|x| x.1).sum();
            out += &format!(",{t:.1}");
        }
        out.push('\n');
    }
    out
}

pub use crate::parent::{die_with_parent, PARENT_ENV};

/// Runs every point not finished before (a point is kept when its settings file and its
/// complete report are there), then writes `sweep.csv` and `sweep.svg` into `a.out`.
pub fn sweep(a: &SweepRequest, components: &crate::Components) -> Result<SweepSummary> {
    let grid = match (&a.grid, a.quick) {
        (Some(p), _) => {
            let text =
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            toml::from_str(&text).with_context(|| format!("{}: invalid grid", p.display()))?
        }
        (None, true) => Grid::quick(),
        (None, false) => Grid::default_grid(&components.method_names()),
    };
    let points = grid.points();
    if points.is_empty() {
        bail!("the grid has no point (no preset?)");
    }
    // The whole grid is checked before its first point runs.
    for (name, preset, overrides) in &points {
        let origin = a.out.join(format!("{name}.toml"));
        let cfg =
            crate::config::load_preset(preset, fipt_pipeline::run_config::RunConfig::preset, None)
                .and_then(|base| {
                    crate::config::load_text(base, &overrides_toml(overrides), &origin, None)
                })
                .and_then(|cfg| crate::run::check(&cfg, preset, components).map(|_| ()));
        cfg.with_context(|| {
            let from = a
                .grid
                .as_ref()
                .map_or(String::new(), |g| format!(" of {}", g.display()));
            format!("grid point {name}{from} (preset {preset})")
        })?;
    }
    // Its own lock file: the points' runs below take theirs in their folders.
    let _lock =
        fipt_core::lock::OutputLock::acquire_named(&a.out, ".fipt.sweep.lock", "fipt sweep")?;
    let mut rows = Vec::new();
    for (k, (name, preset, overrides)) in points.iter().enumerate() {
        let dir = a.out.join(name);
        let settings = overrides_toml(overrides);
        let cfg = a.out.join(format!("{name}.toml"));
        let same = std::fs::read_to_string(&cfg).is_ok_and(|t| t == settings);
        if same {
            if let Some(r) = read_row(&dir, name, preset, &settings) {
                crate::note!("[{}/{}] {name}: finished before, kept", k + 1, points.len());
                rows.push(r);
                continue;
            }
        }
        std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
        fipt_core::fsutil::write_bytes_atomic(&cfg, settings.as_bytes())?;
        crate::note!(
            "[{}/{}] {name}: fipt run --preset {preset}",
            k + 1,
            points.len()
        );
        let status = std::process::Command::new(&a.exe)
            .arg("run")
            .arg(&a.scene)
            .arg("--out")
            .arg(&dir)
            .args(["--preset", preset])
            .arg("--config")
            .arg(&cfg)
            .stdout(std::process::Stdio::null())
            // The run ends with this process (`die_with_parent`): a killed sweep leaves
            // nothing running that would hold a point's folder.
            .env(PARENT_ENV, std::process::id().to_string())
            .status()
            .context("running fipt run")?;
        if !status.success() {
            let report = dir.join("report.json");
            let more = if report.is_file() {
                format!("; its report: {}", report.display())
            } else {
                String::new()
            };
            bail!("point {name} failed ({status}): its error is printed above{more}");
        }
        rows.push(
            read_row(&dir, name, preset, &settings)
                .with_context(|| format!("reading the results of {}", dir.display()))?,
        );
    }
    fipt_core::fsutil::write_bytes_atomic(&a.out.join("sweep.csv"), csv(&rows).as_bytes())?;
    let svg = crate::sweep_plot::svg(&rows, &grid.preset_points());
    fipt_core::fsutil::write_bytes_atomic(&a.out.join("sweep.svg"), svg.as_bytes())?;
    Ok(SweepSummary {
        rows,
        csv: a.out.join("sweep.csv"),
        svg: a.out.join("sweep.svg"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn g_with_steps() -> Grid {
        toml::from_str("presets = [\"fast\"]\n[axes]\n\"train.steps\" = [100]\n").unwrap()
    }

    #[test]
    fn a_grid_crosses_presets_with_every_combination_of_its_axes() {
        let g: Grid = toml::from_str(
            "presets = [\"fast\", \"balanced\"]\n[axes]\n\"train.steps\" = [100, 200]\n\"bake.diffuse_samples\" = [8, 16, 32]\n",
        )
        .unwrap();
        let p = g.points();
        assert_eq!(p.len(), 2 * 2 * 3);
        assert_eq!(p[0].0, "fast_diffuse_samples=8_steps=100");
        let t = overrides_toml(&p[0].2);
        assert!(
            t.contains("[bake]") && t.contains("diffuse_samples = 8") && t.contains("steps = 100"),
            "{t}"
        );
        assert!(toml::from_str::<Grid>("presets = []\nsteps = 3\n").is_err());
        // The default grid runs every method the binary has, and marks each preset of each.
        let g = Grid::default_grid(&["fipt", "ipt"]);
        let names: Vec<String> = g.points().into_iter().map(|p| p.0).collect();
        assert_eq!(names.len(), 6);
        assert!(
            names.contains(&"balanced_method=ipt".to_string()),
            "{names:?}"
        );
        assert_eq!(g.preset_points(), names);
        let t = overrides_toml(&g.points()[1].2);
        assert!(
            t.contains("[pipeline]") && t.contains("method = \"ipt\""),
            "{t}"
        );
        assert!(Grid::default_grid(&["fipt"]).axes.is_empty());
        assert!(g_with_steps().preset_points().is_empty());
    }

    #[test]
    fn one_at_a_time_changes_one_axis_around_each_preset() {
        let g: Grid = toml::from_str(
            "presets = [\"fast\"]\nvary = \"one_at_a_time\"\n[axes]\n\"train.steps\" = [500, 2000]\n\"render.val_spp\" = [128]\n",
        )
        .unwrap();
        let names: Vec<String> = g.points().into_iter().map(|p| p.0).collect();
        assert_eq!(
            names,
            [
                "fast",
                "fast_val_spp=128",
                "fast_steps=500",
                "fast_steps=2000"
            ]
        );
        assert_eq!(g.preset_points(), ["fast"]);
        assert!(g.points().iter().all(|p| p.2.len() <= 1));
        assert!(toml::from_str::<Grid>("presets = [\"fast\"]\nvary = \"diagonal\"\n").is_err());
    }
}
