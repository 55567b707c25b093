//! The time-against-error plot, drawn as plain SVG: log–log, one point per
//! engine × mode × scene, one colour per engine × mode.

use crate::bench_report::Row;
use std::fmt::Write as _;

const WIDTH: f64 = 860.0;
const HEIGHT: f64 = 560.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 250.0;
const TOP: f64 = 40.0;
const BOTTOM: f64 = 60.0;
/// Errors below this (exact results) are drawn on the bottom edge.
const ERROR_FLOOR: f64 = 0.1;

const COLOURS: [&str; 10] = ["#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02", "#a6761d", "#666666", "#1f78b4", "#b2df8a"];

fn decades(lo: f64, hi: f64) -> (f64, f64) {
    (lo.log10().floor(), hi.log10().ceil().max(lo.log10().floor() + 1.0))
}

pub fn time_vs_error(rows: &[Row]) -> String {
    let points: Vec<(&Row, f64, f64)> =
        rows.iter().filter_map(|r| r.accuracy.as_ref().map(|a| (r, r.time.median * 1e3, a.max_ulps.max(ERROR_FLOOR)))).collect();
    let mut series: Vec<String> = Vec::new();
    for (r, _, _) in &points {
        let name = format!("{} · {}", r.engine, r.mode);
        if !series.contains(&name) {
            series.push(name);
        }
    }
    let (t_lo, t_hi) = points.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
    let (e_lo, e_hi) = points.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| (lo.min(p.2), hi.max(p.2)));
    let (tx0, tx1) = if points.is_empty() { (0.0, 1.0) } else { decades(t_lo, t_hi) };
    let (ey0, ey1) = if points.is_empty() { (0.0, 1.0) } else { decades(e_lo, e_hi) };
    let plot_w = WIDTH - LEFT - RIGHT;
    let plot_h = HEIGHT - TOP - BOTTOM;
    let x = |ms: f64| LEFT + (ms.log10() - tx0) / (tx1 - tx0) * plot_w;
    let y = |ulps: f64| TOP + plot_h - (ulps.log10() - ey0) / (ey1 - ey0) * plot_h;

    let mut s = String::new();
    let _ = writeln!(s, r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" font-family="sans-serif" font-size="12">"#);
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ =
        writeln!(s, r#"<text x="{}" y="22" font-size="15" text-anchor="middle">Run time against error (each point: one scene)</text>"#, LEFT + plot_w / 2.0);
    for d in tx0 as i32..=tx1 as i32 {
        let px = x(10f64.powi(d));
        let _ = writeln!(s, r##"<line x1="{px:.1}" y1="{TOP}" x2="{px:.1}" y2="{:.1}" stroke="#ddd"/>"##, TOP + plot_h);
        let _ = writeln!(s, r#"<text x="{px:.1}" y="{:.1}" text-anchor="middle">{}</text>"#, TOP + plot_h + 16.0, label(d));
    }
    for d in ey0 as i32..=ey1 as i32 {
        let py = y(10f64.powi(d));
        let _ = writeln!(s, r##"<line x1="{LEFT}" y1="{py:.1}" x2="{:.1}" y2="{py:.1}" stroke="#ddd"/>"##, LEFT + plot_w);
        let _ = writeln!(s, r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#, LEFT - 6.0, py + 4.0, label(d));
    }
    let _ = writeln!(s, r##"<rect x="{LEFT}" y="{TOP}" width="{plot_w}" height="{plot_h}" fill="none" stroke="#333"/>"##);
    let _ = writeln!(s, r#"<text x="{}" y="{}" text-anchor="middle">median time per call (ms, log)</text>"#, LEFT + plot_w / 2.0, HEIGHT - 18.0);
    let _ = writeln!(
        s,
        r#"<text transform="translate(18 {}) rotate(-90)" text-anchor="middle">max error (ulp, log; exact results at {ERROR_FLOOR})</text>"#,
        TOP + plot_h / 2.0
    );
    for (r, ms, err) in &points {
        let k = series.iter().position(|n| *n == format!("{} · {}", r.engine, r.mode)).unwrap_or(0);
        let _ = writeln!(
            s,
            r#"<circle cx="{:.1}" cy="{:.1}" r="4.5" fill="{}" fill-opacity="0.8"><title>{}: {} {} — {:.2} ms, {:.3} ulp</title></circle>"#,
            x(*ms),
            y(*err),
            COLOURS[k % COLOURS.len()],
            r.case,
            r.engine,
            r.mode,
            ms,
            err
        );
    }
    for (k, name) in series.iter().enumerate() {
        let ly = TOP + 10.0 + k as f64 * 20.0;
        let lx = WIDTH - RIGHT + 16.0;
        let _ = writeln!(s, r#"<circle cx="{lx}" cy="{ly}" r="5" fill="{}"/>"#, COLOURS[k % COLOURS.len()]);
        let _ = writeln!(s, r#"<text x="{}" y="{}">{}</text>"#, lx + 10.0, ly + 4.0, name);
    }
    s.push_str("</svg>\n");
    s
}

fn label(decade: i32) -> String {
    let v = 10f64.powi(decade);
    if decade >= 0 { format!("{v:.0}") } else { format!("{v}") }
}
