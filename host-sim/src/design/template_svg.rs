//! The 1:1 cutting template of a landmark profile: an SVG whose user unit is the millimetre
//! and whose `width`/`height` are given in `mm`, so that it prints to scale (print at 100 %,
//! no "fit to page"; the 100 mm scale bar checks it). The profile is drawn as the closed
//! outline of the piece (the profile and its base on the wall), with the overall width W
//! and height H dimensioned and every vertex listed.

use std::fmt::Write as _;

/// Margin around the drawing, mm.
const MARGIN_MM: f64 = 20.0;

/// The template of `profile` (`(along_m, height_m)` points, along from −W/2 to +W/2,
/// height out of the wall) for a landmark called `title`.
pub fn template(title: &str, profile: &[(f64, f64)]) -> String {
    let mm: Vec<(f64, f64)> = profile.iter().map(|&(u, h)| (u * 1e3, h * 1e3)).collect();
    let (mut x0, mut x1, mut y0, mut y1) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for &(x, y) in &mm {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    let (w, h) = (x1 - x0, y1 - y0);
    // Page: the piece, dimension lines, the vertex table and the scale bar below.
    let text_rows = mm.len() as f64 + 4.0;
    let page_w = (w + 2.0 * MARGIN_MM).max(130.0 + 2.0 * MARGIN_MM);
    let page_h = h + 2.0 * MARGIN_MM + 30.0 + text_rows * 5.0;
    // SVG y grows downwards: the wall (height 0) at the bottom of the piece.
    let ox = MARGIN_MM - x0;
    let oy = MARGIN_MM + 10.0 + y1;
    let pt = |(x, y): (f64, f64)| format!("{:.3},{:.3}", ox + x, oy - y);
    let mut outline: Vec<String> = mm.iter().map(|&p| pt(p)).collect();
    // Close along the wall (height 0) from the last vertex back to the first.
    if let (Some(&first), Some(&last)) = (mm.first(), mm.last()) {
        outline.push(pt((last.0, 0.0)));
        outline.push(pt((first.0, 0.0)));
    }
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{page_w:.3}mm" height="{page_h:.3}mm" viewBox="0 0 {page_w:.3} {page_h:.3}">"#
    );
    let _ = writeln!(
        s,
        r#"<title>{} cutting template, 1:1 (millimetres)</title>"#,
        escape(title)
    );
    let _ = writeln!(
        s,
        r#"<text x="{MARGIN_MM}" y="8" font-family="sans-serif" font-size="4">{} — print at 100 %: the bar below is 100 mm</text>"#,
        escape(title)
    );
    let _ = writeln!(
        s,
        r##"<polygon id="profile" points="{}" fill="#dde8f3" stroke="#000" stroke-width="0.3"/>"##,
        outline.join(" ")
    );
    // Dimension W above the piece, H to its right.
    let top = oy - y1 - 5.0;
    let _ = writeln!(
        s,
        r#"<line x1="{:.3}" y1="{top:.3}" x2="{:.3}" y2="{top:.3}" stroke="black" stroke-width="0.2"/>"#,
        ox + x0,
        ox + x1
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.3}" y="{:.3}" font-family="sans-serif" font-size="3.5" text-anchor="middle">W = {w:.1} mm</text>"#,
        ox + (x0 + x1) / 2.0,
        top - 1.5
    );
    let right = ox + x1 + 5.0;
    let _ = writeln!(
        s,
        r#"<line x1="{right:.3}" y1="{:.3}" x2="{right:.3}" y2="{:.3}" stroke="black" stroke-width="0.2"/>"#,
        oy - y1,
        oy - y0
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.3}" y="{:.3}" font-family="sans-serif" font-size="3.5">H = {h:.1} mm</text>"#,
        right + 1.5,
        oy - (y0 + y1) / 2.0
    );
    // Scale bar and vertex table.
    let bar_y = oy - y0 + 15.0;
    let _ = writeln!(
        s,
        r#"<rect id="scale-100mm" x="{MARGIN_MM}" y="{bar_y:.3}" width="100" height="2" fill="black"/>"#
    );
    let _ = writeln!(
        s,
        r#"<text x="{MARGIN_MM}" y="{:.3}" font-family="sans-serif" font-size="3.5">100 mm</text>"#,
        bar_y + 6.0
    );
    let mut y = bar_y + 14.0;
    let _ = writeln!(
        s,
        r#"<text x="{MARGIN_MM}" y="{y:.3}" font-family="sans-serif" font-size="3.5">vertices (along, out of the wall) in mm from the centre of the base:</text>"#
    );
    for &(u, v) in &mm {
        y += 5.0;
        let _ = writeln!(
            s,
            r#"<text x="{MARGIN_MM}" y="{y:.3}" font-family="monospace" font-size="3.5">{u:9.1} {v:9.1}</text>"#
        );
    }
    s.push_str("</svg>\n");
    s
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The outline's points read back from a template (for checks): `(x, y)` in mm.
pub fn outline_mm(svg: &str) -> Option<Vec<(f64, f64)>> {
    let start = svg.find(r#"id="profile" points=""#)? + r#"id="profile" points=""#.len();
    let end = start + svg[start..].find('"')?;
    svg[start..end]
        .split_whitespace()
        .map(|p| {
            let (x, y) = p.split_once(',')?;
            Some((x.parse().ok()?, y.parse().ok()?))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::LandmarkChoice;

    #[test]
    fn the_outline_measures_w_and_h_in_millimetres() {
        let p1 = LandmarkChoice::parse("p1", Some(&[0.28, 0.3, 9.0])).unwrap();
        let svg = template("P1", &p1.profile());
        assert!(svg.contains(r#"mm" height=""#) && svg.contains("viewBox"));
        let pts = outline_mm(&svg).unwrap();
        let (x0, x1) = pts
            .iter()
            .fold((f64::MAX, f64::MIN), |a, p| (a.0.min(p.0), a.1.max(p.0)));
        let (y0, y1) = pts
            .iter()
            .fold((f64::MAX, f64::MIN), |a, p| (a.0.min(p.1), a.1.max(p.1)));
        assert!((x1 - x0 - 280.0).abs() < 0.01, "{}", x1 - x0);
        assert!((y1 - y0 - 300.0).abs() < 0.01, "{}", y1 - y0);
        assert!(svg.contains("W = 280.0 mm") && svg.contains("H = 300.0 mm"));
        assert!(svg.contains(r#"id="scale-100mm" x="20" y=""#) && svg.contains(r#"width="100""#));
    }
}
