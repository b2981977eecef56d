//! A small SVG line chart: the scene plots of the documentation page, drawn at package time
//! (no plotting library, no Python, no script in the page).

fn escape(s: &str) -> String {
    quick_xml::escape::escape(s).into_owned()
}

/// Distinguishable on white and in grey print.
const COLOURS: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
];

/// One curve.
pub struct Series<'a> {
    pub label: String,
    pub y: &'a [f64],
}

/// 1, 2 or 5 × 10^k ticks covering [lo, hi].
pub(super) fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(f64::MIN_POSITIVE);
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|f| f * mag)
        .find(|s| span / s <= 6.0)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

/// A tick's label: four decimals at most, exponent form outside [1e-3, 1e4).
pub(super) fn label(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-3 {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// An SVG chart of `series` against `t`, with axes, ticks, a title and a legend.
pub fn chart(title: &str, x_label: &str, t: &[f64], series: &[Series]) -> String {
    let (w, h) = (720.0, 300.0);
    let (left, right, top, bottom) = (70.0, 150.0, 30.0, 40.0);
    let (pw, ph) = (w - left - right, h - top - bottom);
    let finite = |v: &&f64| v.is_finite();
    let t0 = t.first().copied().unwrap_or(0.0);
    let t1 = t.last().copied().unwrap_or(1.0).max(t0 + 1e-12);
    let mut lo = series
        .iter()
        .flat_map(|s| s.y.iter().filter(finite))
        .cloned()
        .fold(f64::INFINITY, f64::min);
    let mut hi = series
        .iter()
        .flat_map(|s| s.y.iter().filter(finite))
        .cloned()
        .fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() || !hi.is_finite() {
        (lo, hi) = (-1.0, 1.0);
    }
    if hi - lo <= 1e-12 * hi.abs().max(lo.abs()).max(1e-300) {
        let pad = if hi == 0.0 { 1.0 } else { 0.1 * hi.abs() };
        (lo, hi) = (lo - pad, hi + pad);
    } else {
        let pad = 0.05 * (hi - lo);
        (lo, hi) = (lo - pad, hi + pad);
    }
    let x = |v: f64| left + (v - t0) / (t1 - t0) * pw;
    let y = |v: f64| top + (hi - v) / (hi - lo) * ph;
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"sans-serif\" font-size=\"12\">\n<title>{}</title>\n<rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>\n<text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"14\">{}</text>\n",
        escape(title),
        left + pw / 2.0,
        escape(title)
    );
    for v in ticks(lo, hi) {
        let yy = y(v);
        s.push_str(&format!(
            "<line x1=\"{left}\" x2=\"{}\" y1=\"{yy:.1}\" y2=\"{yy:.1}\" stroke=\"#ddd\"/><text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>\n",
            left + pw,
            left - 6.0,
            yy + 4.0,
            label(v)
        ));
    }
    for v in ticks(t0, t1) {
        let xx = x(v);
        s.push_str(&format!(
            "<line x1=\"{xx:.1}\" x2=\"{xx:.1}\" y1=\"{top}\" y2=\"{}\" stroke=\"#eee\"/><text x=\"{xx:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n",
            top + ph,
            top + ph + 16.0,
            label(v)
        ));
    }
    s.push_str(&format!(
        "<rect x=\"{left}\" y=\"{top}\" width=\"{pw}\" height=\"{ph}\" fill=\"none\" stroke=\"#333\"/>\n<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n",
        left + pw / 2.0,
        h - 6.0,
        escape(x_label)
    ));
    for (k, series) in series.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let points: Vec<String> = t
            .iter()
            .zip(series.y)
            .filter(|(_, v)| v.is_finite())
            .map(|(tt, v)| format!("{:.1},{:.1}", x(*tt), y(*v)))
            .collect();
        s.push_str(&format!(
            "<polyline fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\" points=\"{}\"/>\n",
            points.join(" ")
        ));
        let ly = top + 14.0 + 18.0 * k as f64;
        s.push_str(&format!(
            "<line x1=\"{}\" x2=\"{}\" y1=\"{ly}\" y2=\"{ly}\" stroke=\"{colour}\" stroke-width=\"2\"/><text x=\"{}\" y=\"{}\">{}</text>\n",
            left + pw + 10.0,
            left + pw + 30.0,
            left + pw + 35.0,
            ly + 4.0,
            escape(&series.label)
        ));
    }
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chart_is_well_formed_with_one_polyline_per_series() {
        let t: Vec<f64> = (0..11).map(|k| k as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|v| v.sin()).collect();
        let flat = vec![2.0; 11];
        let svg = chart(
            "a <b>",
            "t (s)",
            &t,
            &[
                Series {
                    label: "sin".into(),
                    y: &y,
                },
                Series {
                    label: "flat".into(),
                    y: &flat,
                },
            ],
        );
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert!(svg.contains("a &lt;b&gt;"));
        let mut reader = quick_xml::Reader::from_str(&svg);
        loop {
            match reader.read_event() {
                Ok(quick_xml::events::Event::Eof) => break,
                Ok(_) => {}
                Err(e) => panic!("{e}"),
            }
        }
        assert_eq!(ticks(0.0, 1.0).len(), 6);
    }
}
