//! The sweep's plot as SVG (text stays text, no font or plotting dependency): kd, σ and
//! re-render PSNR against wall time, one panel each, the Pareto front (no faster point is as
//! accurate) as a line, the presets as filled squares, other points as circles.
use std::fmt::Write;

/// One measured point.
#[derive(Clone, Debug)]
pub struct Row {
    pub name: String,
    pub preset: String,
    pub settings: String,
    pub seconds: f64,
    pub stages: Vec<(String, f64)>,
    pub peak_mib: f64,
    pub kd: Option<f64>,
    pub sigma: Option<f64>,
    pub render: Option<f64>,
    pub metal_recall: Option<f64>,
    pub iou: Option<f64>,
}

const W: f64 = 360.0;
const H: f64 = 260.0;
const M: f64 = 46.0;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Indices of the Pareto front of (time, value): sorted by time, each more accurate than
/// every faster point.
pub fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len()).collect();
    idx.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0));
    let mut best = f64::NEG_INFINITY;
    idx.into_iter()
        .filter(|&i| {
            let keep = points[i].1 > best;
            best = best.max(points[i].1);
            keep
        })
        .collect()
}

fn panel(
    s: &mut String,
    x0: f64,
    title: &str,
    rows: &[Row],
    value: impl Fn(&Row) -> Option<f64>,
    presets: &[String],
) {
    let pts: Vec<(usize, f64, f64)> = rows
        .iter()
        .enumerate()
        .filter_map(|(i, r)| value(r).map(|v| (i, r.seconds / 60.0, v)))
        .collect();
    let _ = write!(s, "<g transform=\"translate({x0},0)\"><text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-weight=\"bold\">{}</text>", W / 2.0, esc(title));
    let _ = write!(
        s,
        "<rect x=\"{M}\" y=\"30\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#888\"/>",
        W - M - 10.0,
        H - 30.0 - M
    );
    if pts.is_empty() {
        s.push_str("</g>");
        return;
    }
    let (tmax, vmin, vmax) = pts
        .iter()
        .fold((0f64, f64::INFINITY, f64::NEG_INFINITY), |a, p| {
            (a.0.max(p.1), a.1.min(p.2), a.2.max(p.2))
        });
    let (vlo, vhi) = ((vmin - 0.5).floor(), (vmax + 0.5).ceil());
    let tmax = (tmax * 1.1).max(0.1);
    let x = |t: f64| M + t / tmax * (W - M - 10.0);
    let y = |v: f64| 30.0 + (vhi - v) / (vhi - vlo) * (H - 30.0 - M);
    for k in 0..=4 {
        let t = tmax * k as f64 / 4.0;
        let v = vlo + (vhi - vlo) * k as f64 / 4.0;
        let _ = write!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\" text-anchor=\"middle\">{t:.1}</text>",
            x(t),
            H - M + 14.0
        );
        let _ = write!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\" text-anchor=\"end\">{v:.1}</text>",
            M - 4.0,
            y(v) + 3.0
        );
    }
    let _ = write!(
        s,
        "<text x=\"{}\" y=\"{}\" font-size=\"11\" text-anchor=\"middle\">wall time (min)</text>",
        W / 2.0,
        H - 12.0
    );
    let _ = write!(s, "<text x=\"12\" y=\"{}\" font-size=\"11\" transform=\"rotate(-90 12 {})\" text-anchor=\"middle\">dB</text>", H / 2.0, H / 2.0);
    let front = pareto(&pts.iter().map(|p| (p.1, p.2)).collect::<Vec<_>>());
    let line: Vec<String> = front
        .iter()
        .map(|&i| format!("{:.1},{:.1}", x(pts[i].1), y(pts[i].2)))
        .collect();
    let _ = write!(
        s,
        "<polyline points=\"{}\" fill=\"none\" stroke=\"#2a7\" stroke-width=\"2\"/>",
        line.join(" ")
    );
    for &(i, t, v) in &pts {
        let r = &rows[i];
        let (cx, cy) = (x(t), y(v));
        if presets.contains(&r.name) {
            let _ = write!(
                s,
                "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"8\" height=\"8\" fill=\"#c33\"/>",
                cx - 4.0,
                cy - 4.0
            );
        } else {
            let _ = write!(
                s,
                "<circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"3.5\" fill=\"#36c\"/>"
            );
        }
        let _ = write!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"9\">{}</text>",
            cx + 6.0,
            cy - 5.0,
            esc(&r.name)
        );
    }
    s.push_str("</g>");
}

/// The plot of `rows`; `presets` names the points drawn as presets.
pub fn svg(rows: &[Row], presets: &[String]) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" font-family=\"sans-serif\"><rect width=\"100%\" height=\"100%\" fill=\"white\"/>",
        3.0 * W,
        H + 16.0
    );
    panel(&mut s, 0.0, "kd PSNR (val)", rows, |r| r.kd, presets);
    panel(&mut s, W, "σ PSNR (val)", rows, |r| r.sigma, presets);
    panel(
        &mut s,
        2.0 * W,
        "re-render PSNR (val)",
        rows,
        |r| r.render,
        presets,
    );
    let _ = write!(s, "<text x=\"8\" y=\"{}\" font-size=\"10\">red squares: presets; green line: Pareto front (no faster point is as accurate)</text></svg>", H + 10.0);
    s
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_front_keeps_each_point_no_faster_point_beats() {
        let p = [
            (1.0, 20.0),
            (2.0, 19.0),
            (3.0, 25.0),
            (0.5, 10.0),
            (4.0, 25.0),
        ];
        assert_eq!(super::pareto(&p), vec![3, 0, 2]);
    }
}
