//! `report.html`: one static page, relative links only, its CSS and script inline.
use crate::{Result, ViewPictures, MAPS};
use serde_json::Value;
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// `s` escaped for HTML and SVG text and attributes.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn read(path: &Path) -> Value {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or(Value::Null)
}

fn num(v: &Value, digits: usize) -> String {
    v.as_f64()
        .filter(|x| x.is_finite())
        .map_or("–".into(), |x| format!("{x:.digits$}"))
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:1.5em;background:#fafafa;color:#222}
h1{font-size:1.5em}h2{margin-top:1.6em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:.25em .6em;text-align:right}
th{background:#eee}td:first-child,th:first-child{text-align:left}
.view{display:flex;flex-wrap:wrap;gap:.8em;align-items:flex-start;margin:1em 0;padding:.6em;background:#fff;border:1px solid #ddd}
figure{margin:0}figcaption{font-size:.85em;color:#555;text-align:center}
.cmp{position:relative;line-height:0}.cmp img{display:block;max-width:none}
.cmp .top{position:absolute;top:0;left:0;width:50%;overflow:hidden;border-right:2px solid #fff}
.cmp input{display:block;width:100%;margin:4px 0 0 0}.pair{display:flex;flex-direction:column;gap:2px}
img{image-rendering:pixelated}img.sheet{max-width:100%;height:auto;image-rendering:auto}";

const SCRIPT: &str = "window.__errors=[];
window.addEventListener('error',function(e){window.__errors.push(String(e.message||(e.target&&e.target.src)||'error'));},true);
window.addEventListener('load',function(){var im=Array.prototype.slice.call(document.images);
var bad=im.filter(function(i){return !(i.complete&&i.naturalWidth>0);});
document.body.setAttribute('data-images',im.length);document.body.setAttribute('data-images-bad',bad.length);
document.body.setAttribute('data-errors',window.__errors.length);});
function slide(r){r.parentNode.querySelector('.top').style.width=r.value+'%';}";

fn header(h: &mut String, report: &Value) {
    let s = |k: &str| report[k].as_str().unwrap_or("–").to_string();
    let _ = write!(
        h,
        "<h1>fipt run: {}</h1>\n<p>preset <b>{}</b>, method <b>{}</b>, reflectance model <b>{}</b>, fipt {} — {}</p>\n",
        esc(&s("scene")),
        esc(&s("preset")),
        esc(report["settings"]["pipeline"]["method"].as_str().unwrap_or("fipt")),
        esc(report["settings"]["model"]["brdf"].as_str().unwrap_or("–")),
        esc(&s("fipt_version")),
        time_in_all(report)
    );
}

/// "N s in all", or for a run that reused finished stages, what they took to compute and
/// what this run took.
fn time_in_all(report: &Value) -> String {
    let reused = report["stages_reused"].as_u64().unwrap_or(0);
    let this = num(&report["seconds_total"], 1);
    if reused == 0 {
        return format!("{this} s in all");
    }
    let n = report["stages"].as_array().map_or(0, |a| a.len());
    match report["seconds_computed_total"].as_f64() {
        Some(t) => format!(
            "{t:.1} s of computing; {reused} of the {n} stages were reused from an earlier run of this folder (this run: {this} s)"
        ),
        None => format!("{this} s in this run, which reused {reused} of {n} stages of an earlier run"),
    }
}

/// `report.json`'s warnings (LDR views, clipped lights, misregistered edges, no light found)
/// at the top of the page, where a reader cannot miss them.
fn warnings(h: &mut String, report: &Value, views: &[ViewPictures]) {
    let mut w: Vec<Value> = report["warnings"].as_array().cloned().unwrap_or_default();
    let missing: Vec<String> = views
        .iter()
        .flat_map(|v| {
            v.maps
                .iter()
                .zip(MAPS)
                .filter(|(m, _)| m.0.is_none())
                .map(move |(_, (name, _, _))| format!("{}/{:03}_{name}", v.split, v.index))
        })
        .collect();
    if !missing.is_empty() {
        w.push(Value::from(format!(
            "{} map(s) of the run are missing ({}): the folder was changed after the run; `fipt run` on it writes them again",
            missing.len(),
            missing.join(", ")
        )));
    }
    if w.is_empty() {
        return;
    }
    let _ = writeln!(
        h,
        "<div class=\"warnings\" style=\"border:2px solid #c60;background:#fff4e5;padding:0.5em 1em\"><h2>Warnings ({})</h2><ul>",
        w.len()
    );
    for x in w {
        let _ = writeln!(h, "<li>{}</li>", esc(x.as_str().unwrap_or("")));
    }
    h.push_str("</ul></div>\n");
}

/// The JSON at `path` when it was written after the run's `report.json` (`Null` otherwise: the
/// scores of an earlier run of the folder, which `fipt run` does not remove).
fn scores_of_this_run(run: &Path, path: &Path) -> Value {
    let modified = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).ok();
    match (modified(path), modified(&run.join("report.json"))) {
        (Some(scores), Some(report)) if scores < report => Value::Null,
        _ => read(path),
    }
}

/// The scores of `metrics.json` (the scene's own ground truth), and those of
/// `eval/cameras-from/metrics.json` (`fipt eval SRC OUT --cameras-from SRC`: a copy's run
/// scored against its source's truth), whichever the run has.
fn metrics_tables(h: &mut String, metrics: &Value, cameras_from: &Value) {
    if metrics.is_object() {
        metrics_table(h, metrics, "Metrics");
    }
    if cameras_from.is_object() {
        h.push_str("<h2>Scored against another scene's ground truth</h2>\n");
        for (name, m) in cameras_from.as_object().into_iter().flatten() {
            let c = &m["cameras_from"];
            let scales = if c["scales_fitted"].as_bool() == Some(true) {
                format!(
                    "; after one fitted kd scale (×{}) and one radiance scale (×{}): {}",
                    num(&c["scales"]["kd"], 3),
                    num(&c["scales"]["radiance"], 3),
                    esc(c["why"].as_str().unwrap_or(""))
                )
            } else {
                String::new()
            };
            let _ = writeln!(
                h,
                "<p><code>fipt eval --cameras-from</code>: the recovered scene rendered at the {} cameras of <code>{}</code> and scored against its truth{scales}.</p>",
                esc(name),
                esc(c["truth"].as_str().unwrap_or("?"))
            );
        }
        metrics_table(h, cameras_from, "");
    }
    if !metrics.is_object() && !cameras_from.is_object() {
        h.push_str("<p>No ground truth: no metrics (for a copy of a scene that has one, <code>fipt eval SRC OUT --cameras-from SRC</code> scores it, and <code>fipt report OUT</code> then shows the scores here).</p>\n");
    }
}

/// The table of `metrics`' split means under the heading `title` (none: empty).
fn metrics_table(h: &mut String, metrics: &Value, title: &str) {
    let Some(splits) = metrics.as_object() else {
        return;
    };
    if !title.is_empty() {
        let _ = writeln!(h, "<h2>{}</h2>", esc(title));
    }
    h.push_str("<table><tr><th>split</th><th>kd dB</th><th>σ dB</th><th>emission IoU</th><th>re-render dB</th></tr>\n");
    for (name, m) in splits {
        let m = &m["mean"];
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(name),
            num(&m["kd_psnr"], 2),
            num(&m["roughness_psnr"], 2),
            num(&m["emission_iou"], 3),
            num(&m["render_psnr"], 2)
        );
    }
    h.push_str("</table>\n<p>Means over the views (PSNR as in the method's protocol; the per-view figures are in metrics.json).</p>\n");
}

fn stages_table(h: &mut String, report: &Value) {
    let Some(stages) = report["stages"].as_array() else {
        return;
    };
    h.push_str(
        "<h2>Stages</h2>\n<table><tr><th>stage</th><th>seconds</th><th>peak RSS MiB</th></tr>\n",
    );
    for st in stages {
        let seconds = if st["reused"].as_bool() == Some(true) {
            format!(
                "{} (reused: {} s in an earlier run)",
                num(&st["seconds"], 1),
                num(&st["computed_seconds"], 1)
            )
        } else {
            num(&st["seconds"], 1)
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(st["stage"].as_str().unwrap_or("?")),
            seconds,
            num(&st["peak_rss_mib"], 0)
        );
    }
    h.push_str("</table>\n");
}

fn lights_table(h: &mut String, report: &Value) {
    let lights = report["emitters"].as_array().cloned().unwrap_or_default();
    let _ = writeln!(h, "<h2>Lights ({})</h2>", lights.len());
    if lights.is_empty() {
        h.push_str("<p>No emitter was found.</p>\n");
        return;
    }
    h.push_str("<table><tr><th>id</th><th>triangles</th><th>area m²</th><th>mean radiance (RGB)</th><th>power W (RGB)</th><th>centroid</th></tr>\n");
    for (k, l) in lights.iter().enumerate() {
        let v3 = |v: &Value, d: usize| {
            v.as_array()
                .map(|a| a.iter().map(|x| num(x, d)).collect::<Vec<_>>().join(", "))
                .unwrap_or("–".into())
        };
        let _ = writeln!(
            h,
            "<tr><td>{k}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            num(&l["triangles"], 0),
            num(&l["area"], 3),
            v3(&l["mean_radiance"], 2),
            v3(&l["power"], 1),
            v3(&l["centroid"], 2)
        );
    }
    h.push_str("</table>\n");
    unpinned_lights(h, report);
}

/// The lights whose radiance the views leave open: the range they allow and how the value
/// was chosen; the views above show kd at the range's ends.
fn unpinned_lights(h: &mut String, report: &Value) {
    let est = report["capture"]["clipped_lights"]["estimates"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let open: Vec<(usize, &Value)> = est
        .iter()
        .enumerate()
        .filter(|(_, x)| x["pinned"].as_bool() == Some(false))
        .collect();
    if open.is_empty() {
        return;
    }
    let _ = writeln!(h, "<h3>Lights the views do not pin ({})</h3>", open.len());
    h.push_str("<p>Each clips in every view and its shading does not fix its radiance: it is set to the value least wrong over rooms, inside the range the views allow (clip levels of the views' luminance: at least what the clipping and the brightest surface it lights say, at most what keeps the darkest above albedo 0.02). Beside kd in the views above: kd if it lay at either end, a first-order estimate (the run's kd re-weighted by the light each pixel would receive), not a second run.</p>\n");
    h.push_str("<table><tr><th>clipped light</th><th>triangles</th><th>chosen (clip levels)</th><th>range</th><th>chosen by</th></tr>\n");
    for (e, x) in open {
        let _ = writeln!(
            h,
            "<tr><td>{e}</td><td>{}</td><td>{}</td><td>{} … {}</td><td>{}</td></tr>",
            num(&x["triangles"], 0),
            num(&x["levels"], 1),
            num(&x["range"][0], 1),
            x["range"][1]
                .as_f64()
                .map_or("no upper bound".into(), |v| format!("{v:.1}")),
            esc(x["chosen_by"].as_str().unwrap_or("?"))
        );
    }
    h.push_str("</table>\n");
}

fn figure(h: &mut String, src: &Option<String>, caption: &str) {
    match src {
        Some(s) => {
            let _ = write!(
                h,
                "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>",
                esc(s),
                esc(caption),
                esc(caption)
            );
        }
        None => {
            let _ = write!(
                h,
                "<figure><figcaption>{} (none)</figcaption></figure>",
                esc(caption)
            );
        }
    }
}

fn view_block(h: &mut String, v: &ViewPictures) {
    let _ = write!(
        h,
        "<div class=\"view\"><div><b>{} view {}</b><br>re-render {} dB</div>",
        esc(&v.split),
        v.index,
        v.psnr.map_or("–".into(), |p| format!("{p:.2}"))
    );
    match &v.render {
        Some(r) => {
            let _ = write!(
                h,
                "<figure><div class=\"cmp\" style=\"width:{w}px\"><img src=\"{}\" alt=\"input\" width=\"{w}\" height=\"{h}\"><div class=\"top\" style=\"height:{h}px\"><img src=\"{}\" alt=\"re-render\" width=\"{w}\" height=\"{h}\"></div><input type=\"range\" min=\"0\" max=\"100\" value=\"50\" oninput=\"slide(this)\"></div><figcaption>re-render (left of the line) | input</figcaption></figure>",
                esc(&v.input),
                esc(r),
                w = v.width,
                h = v.height
            );
        }
        None => figure(h, &Some(v.input.clone()), "input"),
    }
    figure(h, &v.error, "error ×4");
    for ((mine, gt), (name, _, label)) in v.maps.iter().zip(MAPS) {
        h.push_str("<div class=\"pair\">");
        match mine {
            Some(_) => figure(h, mine, label),
            None => {
                let _ = write!(
                    h,
                    "<figure><figcaption><b>{} missing</b>: views/{}/{:03}_{name}.exr</figcaption></figure>",
                    esc(label),
                    esc(&v.split),
                    v.index
                );
            }
        }
        if gt.is_some() {
            figure(h, gt, &format!("{label} (truth)"));
        }
        h.push_str("</div>");
        if name == "kd" && !v.light_ends.is_empty() {
            h.push_str("<div class=\"pair\">");
            for (png, caption) in &v.light_ends {
                figure(h, &Some(png.clone()), caption);
            }
            h.push_str("</div>");
        }
    }
    h.push_str("</div>\n");
}

/// Writes `run/report.html` for the pictures `views` (paths relative to `run`) of the
/// `splits` (name, number of views).
pub fn write_html(
    run: &Path,
    views: &[ViewPictures],
    splits: &[(String, usize)],
) -> Result<PathBuf> {
    let report = read(&run.join("report.json"));
    let metrics = read(&run.join("metrics.json"));
    let cameras_from = scores_of_this_run(run, &run.join("eval/cameras-from/metrics.json"));
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>fipt report</title>\n<style>{STYLE}</style>\n<script>{SCRIPT}</script></head><body>\n"
    );
    header(&mut h, &report);
    warnings(&mut h, &report, views);
    metrics_tables(&mut h, &metrics, &cameras_from);
    h.push_str("<h2>Views</h2>\n<p>Drag a slider to compare the re-render with the input; the error map shows |Δ| of the displayed values ×4 (black → red → yellow → white).</p>\n");
    if report["capture"]["ldr"].as_bool() == Some(true) {
        h.push_str("<p>The views are LDR photos: each re-render is shown as the camera would have taken it, at the view's exposure (the gain the run divided a training view by, where it did; else the best single gain), through the camera's response and clipped at its clip level. Blue in the error map: pixels the photo clips, not scored.</p>\n");
    }
    let shown: Vec<String> = splits
        .iter()
        .map(|(name, total)| {
            let n = views.iter().filter(|v| &v.split == name).count();
            format!("{n} of the {total} {} views", esc(name))
        })
        .collect();
    let _ = writeln!(
        h,
        "<p>Shown: {} (<code>fipt report RUN --views N</code> shows more).</p>",
        shown.join(", ")
    );
    for v in views {
        view_block(&mut h, v);
    }
    lights_table(&mut h, &report);
    stages_table(&mut h, &report);
    if run.join("sweep.png").is_file() {
        h.push_str("<h2>Speed and accuracy</h2>\n<img src=\"sweep.png\" alt=\"accuracy against wall time\">\n");
    }
    for split in ["train", "val"] {
        let s = format!("report/sheet_{split}.png");
        if run.join(&s).is_file() {
            // The sheet has a truth row where the scene has ground truth (as metrics.json).
            let truth = if metrics.is_object() {
                "; the row under it: the truth of the maps"
            } else {
                ""
            };
            let _ = writeln!(h, "<h2>Contact sheet ({split})</h2>\n<p>Per view: input | re-render | error | kd | roughness σ | metallic | emission{truth}. Fitted to the window: <a href=\"{s}\">full size</a>.</p><a href=\"{s}\"><img class=\"sheet\" src=\"{s}\" alt=\"contact sheet {split}\"></a>");
        }
    }
    h.push_str("</body></html>\n");
    let path = run.join("report.html");
    fipt_core::fsutil::write_bytes_atomic(&path, h.as_bytes())?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warnings_head_the_page_escaped_and_absent_without_any() {
        let mut h = String::new();
        warnings(
            &mut h,
            &serde_json::json!({ "warnings": ["NO LIGHT FOUND <b>", "LDR"] }),
            &[],
        );
        assert!(
            h.contains("Warnings (2)") && h.contains("NO LIGHT FOUND &lt;b&gt;"),
            "{h}"
        );
        let mut none = String::new();
        warnings(&mut none, &serde_json::json!({ "warnings": [] }), &[]);
        warnings(&mut none, &serde_json::json!({}), &[]);
        assert!(none.is_empty());
    }
}
