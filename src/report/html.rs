//! HTML pieces: escaping, numbers, captions, the page head and tail (style, the self-
//! test script), inline figures.

use super::Figure;

/// Escape text for HTML.
pub fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c => o.push(c),
        }
    }
    o
}

/// A number for a table: 4 significant digits, integers exact.
pub fn fmt_num(v: f64) -> String {
    if v.fract().abs() < 1e-12 && v.abs() < 1e15 {
        return format!("{}", v as i64);
    }
    let a = v.abs();
    if !(1e-3..1e6).contains(&a) {
        format!("{v:.3e}")
    } else {
        let digits = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{v:.digits$}")
    }
}

/// What each figure shows (the report's captions).
pub fn caption(name: &str) -> &'static str {
    match name {
        "tracks" => {
            "True track (black, dots at samples), distributed estimate θ̄ = mean of the node estimates (blue), centralised ML reference (orange, dashed) and any baselines. Transmitters (red triangles), receivers (squares) and network links drawn to scale, as in Mourya 2017 Fig. 2b. Where bounds are present, the certified error discs around θ̄ are drawn at every n-th sample."
        }
        "error" => {
            "Position error ‖x_k − x_k*‖ per sample for every track, with the Cramér-Rao bound √tr(J⁻¹) at the true position (grey, dashed). The grey region is the burn-in, excluded from rmse_after_burn_in; red regions are the faults of the run (faults.csv). Monte Carlo runs: mean across trials with a 5th–95th percentile band."
        }
        "consensus" => {
            "Each node's estimate θ_v (thin lines), their mean θ̄ and the true position, x and y coordinates against the sample (or against the iteration when the run traced iterations), as Mourya 2017 Fig. 2a; bottom: the consensus disagreement maxᵥ‖θᵥ − θ̄‖."
        }
        "ctte" => {
            "Running cumulative target tracking error CTTE_k = Σ_{j≤k} ‖x_j − x_j*‖ (Pun-So 2022) of every track, and the running dynamic regret (Pun-So 2020) when present. Monte Carlo runs: mean with a 5th–95th percentile band."
        }
        "network" => {
            "The gossip graph to scale. Each node is coloured by its number of prox solves and labelled with its counters: prox solves, gossip messages sent (↑) and received (↓), and declined exchanges."
        }
        "messages" => {
            "The first frames on the acoustic channel as a message-sequence diagram: one line per node, emulated time to the right. Each delivered frame is an arrow from its sender at the start of its transmission to its addressee at the end of its arrival, coloured by kind; a lost frame is a dashed red line to where it would have arrived, with a cross and the reason (loss, collision, half_duplex, blocked, node_down, late)."
        }
        "channel" => {
            "Each directed link's delivery ratio (frames delivered over frames sent, label i→j with the frames sent) against the link's length. Losses grow with range under the range loss model; collisions and half-duplex losses depend on the traffic at the receiver."
        }
        "error-cdf" => {
            "Monte Carlo of one snapshot per trial: the empirical CDF across trials of each track's position error ‖x − x*‖ (the fraction of trials whose error is at most the abscissa), as Gholami 2015 Figs. 8-9 plot it, with the mean Cramér-Rao bound √tr(J⁻¹) (grey, dashed)."
        }
        "tightness" => {
            "The empirical CDF across trials of each certified bound's relative tightness τ = (bound − error) / error, one panel per track that carries bounds (Gholami 2015 Sec. 6: τ ≤ 1 at the 80th percentile means the bound is below twice the actual error in 80 % of the cases)."
        }
        "scatter" => {
            "Every trial's estimate minus the true position, per track, at equal scale on both axes: the truth is the cross at the origin."
        }
        "compare-error" => "Error per sample of every track: run A solid, run B dashed.",
        "compare-ctte" => "Running CTTE of every track: run A solid, run B dashed.",
        _ => "",
    }
}

pub(super) const STYLE: &str = r#"
body { font-family: "DejaVu Sans", "Helvetica Neue", Arial, sans-serif; color: #222; margin: 0; background: #fafafa; }
main { max-width: 1240px; margin: 0 auto; padding: 16px 28px 48px; background: #fff; }
h1 { font-size: 26px; margin: 12px 0 4px; }
h2 { font-size: 20px; border-bottom: 1px solid #ddd; padding-bottom: 4px; margin-top: 36px; }
h3 { font-size: 16px; margin: 20px 0 6px; }
p.sub { color: #555; margin: 0 0 12px; }
table { border-collapse: collapse; margin: 8px 0 12px; font-size: 14px; }
div.scroll { max-width: 100%; overflow-x: auto; }
th, td { border: 1px solid #d4d4d4; padding: 4px 10px; text-align: left; vertical-align: top; }
th { background: #f1f3f5; }
td.num { text-align: right; font-variant-numeric: tabular-nums; font-family: "DejaVu Sans Mono", monospace; }
td.better { background: #e6f4ea; } td.worse { background: #fce8e6; }
.status-ok { color: #137333; font-weight: bold; } .status-bad { color: #b3261e; font-weight: bold; }
figure.plot { margin: 18px 0 28px; }
figure.plot svg { display: block; max-width: 100%; height: auto; border: 1px solid #e3e3e3; }
figcaption { font-size: 14px; color: #444; max-width: 1000px; margin-top: 6px; }
pre { background: #f6f8fa; border: 1px solid #e1e4e8; padding: 8px 12px; overflow-x: auto; font-size: 13px; white-space: pre-wrap; word-break: break-all; }
.grid2 { display: grid; grid-template-columns: 1fr 1fr; gap: 16px; }
.note { color: #666; font-size: 13px; }
details summary { cursor: pointer; color: #1a5fb4; }
"#;

/// The self-test script, run only when the URL contains `?selftest`.
pub(super) const SELFTEST_HEAD: &str = r#"<script>
(function () {
  var errs = [];
  window.__sonarnetErrors = errs;
  window.addEventListener('error', function (e) {
    var t = e.target;
    errs.push(e.message ? String(e.message) : ('failed to load ' + (t && (t.src || t.href || t.tagName))));
  }, true);
  window.addEventListener('unhandledrejection', function (e) { errs.push('unhandled rejection: ' + e.reason); });
  document.addEventListener('securitypolicyviolation', function (e) { errs.push('CSP violation: ' + e.blockedURI); });
  var ce = console.error;
  console.error = function () { errs.push('console.error: ' + Array.prototype.join.call(arguments, ' ')); return ce.apply(console, arguments); };
})();
</script>"#;

pub(super) const SELFTEST_TAIL: &str = r#"<pre id="selftest" hidden></pre>
<script>
(function () {
  function run() {
    if (location.search.indexOf('selftest') < 0) return;
    var meta = document.querySelector('meta[name="sonarnet-plots"]');
    var out = { expected: meta ? parseInt(meta.content, 10) : -1, errors: window.__sonarnetErrors || ['self-test hook missing'], plots: [] };
    var figs = document.querySelectorAll('figure.plot');
    for (var i = 0; i < figs.length; i++) {
      var s = figs[i].querySelector('svg');
      // Content box (without the border), so an empty svg measures 0.
      var w = s ? s.clientWidth : 0, h = s ? s.clientHeight : 0;
      var n = s ? s.querySelectorAll('*').length : 0;
      out.plots.push({ id: figs[i].id, width: w, height: h, elements: n });
    }
    document.getElementById('selftest').textContent = JSON.stringify(out);
  }
  run();
  window.addEventListener('load', run);
})();
</script>"#;

pub(super) fn page_head(title: &str, plots: usize) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; script-src 'unsafe-inline'; img-src data:\">\n\
<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
<meta name=\"sonarnet-plots\" content=\"{plots}\">\n<title>{}</title>\n<style>{STYLE}</style>\n{SELFTEST_HEAD}\n</head>\n<body>\n<main>\n",
        esc(title)
    )
}

pub(super) fn page_tail() -> String {
    format!(
        "<p class=\"note\">Written by sonarnet {}.</p>\n</main>\n{SELFTEST_TAIL}\n</body>\n</html>\n",
        env!("CARGO_PKG_VERSION")
    )
}

/// Strip anything before `<svg` (an XML declaration) so the SVG inlines.
pub(super) fn inline_svg(svg: &str) -> &str {
    svg.find("<svg").map_or(svg, |i| &svg[i..])
}

pub(super) fn figure_html(fig: &Figure, svg: &str) -> String {
    format!(
        "<figure class=\"plot\" id=\"plot-{}\">\n{}\n<figcaption><b>{}.svg</b> — {}</figcaption>\n</figure>\n",
        esc(&fig.name),
        inline_svg(svg),
        esc(&fig.name),
        esc(caption(&fig.name))
    )
}

pub(super) fn status_html(s: Option<crate::pipeline::RunStatus>) -> String {
    match s {
        Some(crate::pipeline::RunStatus::Ok) => "<span class=\"status-ok\">ok</span>".into(),
        Some(s) => format!("<span class=\"status-bad\">{s}</span>"),
        None => "-".into(),
    }
}
