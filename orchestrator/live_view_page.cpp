// The live view's page, embedded in the binary: plain HTML + JavaScript + SVG, no build step, no
// external resources. It polls state.json (live_view.hpp) and redraws. Once a snapshot is drawn the
// body carries data-agents (agents drawn), data-step, data-done and data-rmse (the RMSE as shown),
// which the headless-Chromium test reads.
#include "live_view.hpp"

namespace swarmloc::orchestrator {

const char* live_view_page() {
  return R"PAGE(<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>swarmloc live view</title>
<style>
  body { font: 14px/1.35 system-ui, sans-serif; margin: 0; color: #222; background: #fafafa; }
  header { padding: 8px 14px; background: #263238; color: #eceff1; }
  header b { font-size: 16px; }
  main { display: flex; gap: 12px; padding: 10px; }
  #map { flex: 1 1 auto; background: #fff; border: 1px solid #ccc; min-width: 300px; height: calc(100vh - 64px); }
  #panel { flex: 0 0 270px; }
  table { border-collapse: collapse; width: 100%; }
  td { padding: 2px 4px; border-bottom: 1px solid #eee; }
  td.v { text-align: right; font-variant-numeric: tabular-nums; font-family: ui-monospace, monospace; }
  .legend div { margin: 3px 0; }
  .bar { height: 10px; background: linear-gradient(to right, hsl(0,80%,45%), hsl(60,80%,45%), hsl(120,80%,35%)); }
  .scale { display: flex; justify-content: space-between; font-size: 11px; color: #666; }
  #status { font-size: 12px; color: #666; margin-top: 8px; }
</style>
</head>
<body data-agents="0" data-step="-1" data-done="0" data-rmse="">
<header><b>swarmloc live view</b> &nbsp; <span id="title">connecting…</span></header>
<main>
  <svg id="map" viewBox="0 -40 40 40" preserveAspectRatio="xMidYMid meet"></svg>
  <div id="panel">
    <table>
      <tr><td>step</td><td class="v" id="step">—</td></tr>
      <tr><td>world time</td><td class="v" id="time">—</td></tr>
      <tr><td>phase</td><td class="v" id="phase">—</td></tr>
      <tr><td>RMSE</td><td class="v"><span id="rmse">—</span> m</td></tr>
      <tr><td>mean error</td><td class="v"><span id="mean">—</span> m</td></tr>
      <tr><td>max error</td><td class="v"><span id="max">—</span> m</td></tr>
      <tr><td>CRLB (accumulated)</td><td class="v"><span id="crlb">—</span> m</td></tr>
      <tr><td>bound (<span id="boundkind">—</span>)</td><td class="v"><span id="bound">—</span> m</td></tr>
      <tr><td>NEES (2 = consistent)</td><td class="v" id="nees">—</td></tr>
      <tr><td>agents / anchors</td><td class="v" id="count">—</td></tr>
      <tr><td>scored agents</td><td class="v" id="scored">—</td></tr>
      <tr><td>links delivered</td><td class="v" id="linkfrac">—</td></tr>
      <tr><td>page updates</td><td class="v" id="rate">—</td></tr>
    </table>
    <div class="legend">
      <p><b>Legend</b></p>
      <div><svg width="16" height="12"><circle cx="8" cy="6" r="4.5" fill="none" stroke="#111" stroke-width="1.5"/></svg> truth</div>
      <div><svg width="16" height="12"><rect x="3" y="1" width="10" height="10" fill="#111"/></svg> anchor (truth)</div>
      <div id="target-legend" style="display:none"><svg width="16" height="12"><path d="M8 1 L13 6 L8 11 L3 6 Z" fill="none" stroke="#c62828" stroke-width="2"/></svg> target (truth): every agent estimates it</div>
      <div><svg width="16" height="12"><circle cx="8" cy="6" r="3" fill="#1565c0"/></svg> estimate, <span style="color:#888">grey line: error</span></div>
      <div><svg width="16" height="12"><ellipse cx="8" cy="6" rx="7" ry="4" fill="none" stroke="#1565c0"/></svg> 95 % covariance ellipse <span id="mag"></span></div>
      <div>links, coloured by delivered fraction (1 − lost-sample rate):</div>
      <div class="bar"></div>
      <div class="scale"><span>0</span><span>0.5</span><span>1</span></div>
      <div><svg width="16" height="12"><line x1="0" y1="6" x2="16" y2="6" stroke="#bbb" stroke-dasharray="3,2"/></svg> no counters yet</div>
    </div>
    <div id="status"></div>
  </div>
</main>
<script>
"use strict";
const CHI2_95 = 5.991;  // 2-dof chi-square 95 % quantile
let bounds = null;       // only grows, so the picture does not jitter
let fetchTimes = [];

function fmt(v, digits) { return (v === null || v === undefined) ? "—" : Number(v).toFixed(digits); }
function $(id) { return document.getElementById(id); }

function linkColour(f) {
  if (f === null || f === undefined) return null;
  const hue = Math.round(120 * Math.max(0, Math.min(1, f)));
  return "hsl(" + hue + ",80%," + (hue > 90 ? 35 : 45) + "%)";
}

// Semi-axes (unscaled, 95 %) and rotation (radians, world frame) of a 2x2 covariance [a b; b d].
function ellipseOf(c) {
  const a = c[0], b = 0.5 * (c[1] + c[2]), d = c[3];
  const mid = 0.5 * (a + d), rad = Math.sqrt(0.25 * (a - d) * (a - d) + b * b);
  const l1 = mid + rad, l2 = Math.max(mid - rad, 0);
  if (!(l1 > 0) || !isFinite(l1)) return null;
  const angle = Math.abs(b) > 1e-300 ? Math.atan2(l1 - a, b) : (a >= d ? 0 : Math.PI / 2);
  return { rx: Math.sqrt(CHI2_95 * l1), ry: Math.sqrt(CHI2_95 * l2), angle: angle };
}

// Round magnification (1, 2, 5 x 10^k) so the median semi-major axis is at least 1.5 % of the map,
// the same rule as plots/positions.png.
function magnification(axes, extent) {
  if (axes.length === 0 || !(extent > 0)) return 1;
  axes.sort((x, y) => x - y);
  const median = axes[Math.floor(axes.length / 2)], wanted = 0.015 * extent;
  if (!(median > 0) || median >= wanted) return 1;
  const decade = Math.pow(10, Math.floor(Math.log10(wanted / median)));
  for (const m of [1, 2, 5, 10]) if (m * decade * median >= wanted) return m * decade;
  return 10 * decade;
}

function draw(s) {
  const agents = s.agents || [], links = s.links || [];
  // dle: every agent estimates the target, so errors are measured from it, not from the agent.
  const target = s.target && s.target[0] !== null ? s.target : null;
  const scoredTruth = a => target || a.truth;
  // Map bounds: the area square and every true position, 4 % margin.
  let x0 = 0, y0 = 0, x1 = s.area_m || 1, y1 = s.area_m || 1;
  for (const p of agents.map(a => a.truth).concat(target ? [target] : [])) {
    if (p[0] === null) continue;
    x0 = Math.min(x0, p[0]); x1 = Math.max(x1, p[0]);
    y0 = Math.min(y0, p[1]); y1 = Math.max(y1, p[1]);
  }
  if (bounds) { x0 = Math.min(x0, bounds[0]); y0 = Math.min(y0, bounds[1]); x1 = Math.max(x1, bounds[2]); y1 = Math.max(y1, bounds[3]); }
  bounds = [x0, y0, x1, y1];
  const extent = Math.max(x1 - x0, y1 - y0), pad = 0.04 * extent;
  const map = $("map");
  map.setAttribute("viewBox", (x0 - pad) + " " + (-(y1 + pad)) + " " + (x1 - x0 + 2 * pad) + " " + (y1 - y0 + 2 * pad));
  const r = 0.009 * extent;
  const byId = new Map(agents.map(a => [a.id, a]));
  const parts = [];
  // Links between true positions.
  let delivered = 0, sent = 0;
  for (const l of links) {
    const a = byId.get(l.a), b = byId.get(l.b);
    if (!a || !b) continue;
    const colour = linkColour(l.delivered_fraction);
    delivered += l.delivered; sent += l.sent;
    const tip = l.a + "–" + l.b + ": " + l.delivered + " of " + l.sent + " delivered";
    parts.push('<line class="link" x1="' + a.truth[0] + '" y1="' + (-a.truth[1]) + '" x2="' + b.truth[0] + '" y2="' + (-b.truth[1]) +
      '" stroke="' + (colour || "#bbb") + '"' + (colour ? "" : ' stroke-dasharray="3,2"') +
      ' stroke-width="1.2" stroke-opacity="0.75" vector-effect="non-scaling-stroke"><title>' + tip + '</title></line>');
  }
  // Ellipses (magnified by one round factor for the whole picture), error lines, estimates.
  const shapes = [], axes = [];
  for (const a of agents) {
    if (a.anchor || !a.estimate || !a.covariance) continue;
    const e = ellipseOf(a.covariance);
    if (e) { shapes.push([a, e]); axes.push(e.rx); }
  }
  const mag = magnification(axes, extent);
  $("mag").textContent = mag === 1 ? "" : "(drawn ×" + mag + ")";
  for (const [a, e] of shapes) {
    parts.push('<ellipse class="ellipse" cx="' + a.estimate[0] + '" cy="' + (-a.estimate[1]) + '" rx="' + (mag * e.rx) + '" ry="' + (mag * e.ry) +
      '" transform="rotate(' + (-e.angle * 180 / Math.PI) + ' ' + a.estimate[0] + ' ' + (-a.estimate[1]) + ')"' +
      ' fill="#1565c0" fill-opacity="0.08" stroke="#1565c0" stroke-width="1" vector-effect="non-scaling-stroke"/>');
  }
  let drawn = 0, anchors = 0;
  for (const a of agents) {
    if (a.truth[0] === null) continue;
    if (a.estimate && !a.anchor) {
      const t = scoredTruth(a);
      parts.push('<line x1="' + t[0] + '" y1="' + (-t[1]) + '" x2="' + a.estimate[0] + '" y2="' + (-a.estimate[1]) +
        '" stroke="#888" stroke-width="1" vector-effect="non-scaling-stroke"/>');
    }
    if (a.anchor) {
      anchors++;
      parts.push('<rect class="truth anchor" data-id="' + a.id + '" x="' + (a.truth[0] - r) + '" y="' + (-a.truth[1] - r) +
        '" width="' + (2 * r) + '" height="' + (2 * r) + '" fill="#111"><title>anchor ' + a.id + '</title></rect>');
    } else {
      parts.push('<circle class="truth" data-id="' + a.id + '" cx="' + a.truth[0] + '" cy="' + (-a.truth[1]) + '" r="' + r +
        '" fill="none" stroke="#111" stroke-width="1.5" vector-effect="non-scaling-stroke"><title>agent ' + a.id + ' (truth)</title></circle>');
    }
    drawn++;
  }
  for (const a of agents) {
    if (a.anchor || !a.estimate) continue;
    const t = scoredTruth(a);
    const err = Math.hypot(a.estimate[0] - t[0], a.estimate[1] - t[1]);
    parts.push('<circle class="estimate" data-id="' + a.id + '" cx="' + a.estimate[0] + '" cy="' + (-a.estimate[1]) + '" r="' + (0.55 * r) +
      '" fill="#1565c0"><title>agent ' + a.id + ': error ' + err.toFixed(4) + ' m</title></circle>');
  }
  if (target) {  // on top, as an outline: the estimates it should be among stay visible inside it
    parts.push('<path class="target" d="M' + target[0] + ' ' + (-target[1] - 1.6 * r) + ' l' + (1.6 * r) + ' ' + (1.6 * r) +
      ' l' + (-1.6 * r) + ' ' + (1.6 * r) + ' l' + (-1.6 * r) + ' ' + (-1.6 * r) + ' Z" fill="none" stroke="#c62828"' +
      ' stroke-width="2" vector-effect="non-scaling-stroke"><title>target (truth)</title></path>');
  }
  $("target-legend").style.display = target ? "" : "none";
  map.innerHTML = parts.join("");

  $("title").textContent = (s.name || "") + " · " + (s.algorithm || "") + " · " + (s.mode === "sim" ? "in-process run, paced playback" : "DDS, one process per agent");
  $("step").textContent = s.step < 0 ? "—" : (s.step + 1) + " / " + s.steps;
  $("time").textContent = s.step < 0 ? "—" : fmt(s.time_s, 1) + " s";
  $("phase").textContent = s.phase || "";
  const rmse = fmt(s.rmse_m, 4);
  $("rmse").textContent = rmse;
  $("mean").textContent = fmt(s.mean_error_m, 4);
  $("max").textContent = fmt(s.max_error_m, 4);
  $("crlb").textContent = fmt(s.crlb_rmse_m, 4);
  $("bound").textContent = fmt(s.bound_rmse_m, 4);
  $("boundkind").textContent = s.bound_kind || "—";
  $("nees").textContent = fmt(s.nees, 2);
  $("count").textContent = drawn + " / " + anchors;
  $("scored").textContent = String(s.scored);
  $("linkfrac").textContent = sent > 0 ? (100 * delivered / sent).toFixed(1) + " %" : "—";
  const body = document.body;
  body.dataset.agents = String(drawn);
  body.dataset.step = String(s.step);
  body.dataset.steps = String(s.steps);
  body.dataset.done = s.done ? "1" : "0";
  body.dataset.rmse = rmse;
  body.dataset.crlb = fmt(s.crlb_rmse_m, 4);
}

async function poll() {
  let delay = 200;  // about five updates a second while the run is live
  try {
    const response = await fetch("state.json", { cache: "no-store" });
    const s = await response.json();
    if (s.agents) draw(s);
    const now = performance.now();
    fetchTimes.push(now);
    fetchTimes = fetchTimes.filter(t => now - t < 2000);
    $("rate").textContent = (fetchTimes.length / 2).toFixed(1) + " /s";
    $("status").textContent = s.done ? "run finished; these are the figures in summary.json"
                                     : (s.mode === "sim" ? "playback of the finished in-process run" : "live");
    if (s.done) delay = 1000;
  } catch (err) {
    $("status").textContent = "not connected (the run has ended?) — showing the last state";
    delay = 1000;
  }
  setTimeout(poll, delay);
}
poll();
</script>
</body>
</html>
)PAGE";
}

}  // namespace swarmloc::orchestrator
