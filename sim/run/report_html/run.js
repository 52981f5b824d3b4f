"use strict";
// The report of one run: the part, the time series, the blocks, the ballbar (run_page.py).
(function () {
  const D = K37;
  const AXES = D.axes;
  const B = D.blocks;
  const BLOCKS = B.line.length;
  const COLORS = {x: "#1f77b4", y: "#ff7f0e", z: "#2ca02c", path: "#111"};
  const SCALE = "Viridis";
  // The time-series buckets drawn across the plot's width, at most (twice: least, largest).
  const SERIES_POINTS = 3000;

  const program = {block: unpack(D.program.block)};
  const actual = {block: unpack(D.actual.block), error: unpack(D.actual.error)};
  AXES.forEach((a) => {
    program[a] = unpack(D.program[a]);
    actual[a] = unpack(D.actual[a]);
  });
  const TIME = unpack(D.series.time);

  // What hovering a point of a block says: shared rows, so 65,536 points cost no copies.
  const NONE = ["(no block)", "", "", "", 0, 0, 0];
  const info = [];
  for (let k = 0; k < BLOCKS; k++) {
    info.push([B.label[k], B.line[k], B.index[k], B.code[k], B.feed[k], B.max[k], B.rms[k]]);
  }
  const custom = (owners) => Array.from(owners, (k) => (k >= 0 ? info[k] : NONE));
  const BLOCK_HOVER = "<b>%{customdata[0]}</b> (line %{customdata[1]}, block " +
    "%{customdata[2]}, %{customdata[3]})<br>feed %{customdata[4]:.1f} mm/min<br>" +
    "block contour error: max %{customdata[5]:.2f}, RMS %{customdata[6]:.2f} LSB";

  // -- the part ------------------------------------------------------------------------------
  const part = document.getElementById("part");
  const threeD = D.three_d;
  const errorText = Array.from(actual.error, (e) => e.toFixed(2));
  const coords = (source) => (threeD ? {x: source.x, y: source.y, z: source.z}
    : {x: source.x, y: source.y});
  const kind = threeD ? "scatter3d" : "scattergl";
  const partTraces = [
    Object.assign({type: kind, mode: "lines", name: "programmed",
      line: {color: "#9a9a9a", width: threeD ? 3 : 2}, customdata: custom(program.block),
      hovertemplate: BLOCK_HOVER + "<extra>programmed</extra>"}, coords(program)),
    Object.assign({type: kind, name: "actual", text: errorText, customdata: custom(actual.block),
      hovertemplate: BLOCK_HOVER + "<br>here: %{text} LSB<extra>actual</extra>"},
    coords(actual), threeD ? {mode: "lines", line: {color: actual.error, colorscale: SCALE,
      width: 5, showscale: true, cmin: 0, colorbar: {title: {text: "contour error (LSB)"}}}}
      : {mode: "markers", marker: {color: actual.error, colorscale: SCALE, size: 4, cmin: 0,
        showscale: true, colorbar: {title: {text: "contour error (LSB)"}}}}),
    Object.assign({type: kind, mode: "lines", name: "selected block", hoverinfo: "skip",
      line: {color: "#d62728", width: 6}}, coords({x: [], y: [], z: []})),
    Object.assign({type: kind, mode: "markers", name: "tool", hoverinfo: "skip",
      marker: {color: "#000", size: threeD ? 6 : 12, symbol: threeD ? "diamond" : "x"}},
    coords({x: [], y: [], z: []})),
  ];
  const mmAxis = (name) => ({title: {text: `${name} (mm)`}});
  // The part's extent per axis (mm): in 3-D, true proportions, but Z stretched to at least
  // MIN_Z_ASPECT of the longest side (a few tenths of a millimetre on a part of centimetres).
  const MIN_Z_ASPECT = 0.25;
  const extent = (values) => {
    let lo = Infinity, hi = -Infinity;
    values.forEach((v) => { if (v < lo) lo = v; if (v > hi) hi = v; });
    return hi > lo ? hi - lo : 0;
  };
  function aspect() {
    const sides = ["x", "y", "z"].map((a) => extent(program[a]));
    const longest = Math.max(...sides, 1e-9);
    return {x: Math.max(sides[0] / longest, 0.05), y: Math.max(sides[1] / longest, 0.05),
      z: Math.max(sides[2] / longest, MIN_Z_ASPECT)};
  }
  const partLayout = threeD
    ? {scene: {xaxis: mmAxis("x"), yaxis: mmAxis("y"), zaxis: mmAxis("z"),
      aspectmode: "manual", aspectratio: aspect(),
      camera: {eye: {x: 0.7, y: -1.1, z: 0.6}}, domain: {x: [0, 0.92], y: [0, 1]}}}
    : {xaxis: mmAxis("x"), yaxis: Object.assign(mmAxis("y"), {scaleanchor: "x"})};
  Object.assign(partLayout, {margin: {l: 60, r: 20, t: 30, b: 50}, hovermode: "closest",
    legend: {orientation: "h"}, uirevision: "part"});
  Plotly.newPlot(part, partTraces, partLayout, PLOT_CONFIG);

  // -- the time series -----------------------------------------------------------------------
  const series = document.getElementById("series");
  const S = D.series;
  const LEVELS = S.low[S.panels[0].columns[0]].length;
  const low = {}, high = {};
  for (const column of Object.keys(S.high)) {
    high[column] = S.high[column].map(unpack);
    low[column] = S.low[column].map((packed, k) => (packed ? unpack(packed) : high[column][k]));
  }
  const last = TIME.length ? TIME[TIME.length - 1] : 1;
  const panels = S.panels.length;
  const gap = 0.04, height = (1 - gap * (panels - 1)) / panels;
  const layout = {margin: {l: 70, r: 20, t: 20, b: 45}, hovermode: "x", showlegend: true,
    legend: {orientation: "h", y: 1.02, yanchor: "bottom"},
    xaxis: {title: {text: "time (s)"}, anchor: `y${panels}`, showspikes: true,
      spikemode: "across", spikethickness: 1, range: [TIME[0] || 0, last]}};
  S.panels.forEach((p, k) => {
    const top = 1 - k * (height + gap);
    layout[`yaxis${k ? k + 1 : ""}`] = {domain: [top - height, top], title: {text: p.unit}};
    layout.annotations = (layout.annotations || []).concat([{text: `<b>${p.title}</b>`,
      xref: "paper", yref: "paper", x: 0, y: top, xanchor: "left", yanchor: "bottom",
      showarrow: false}]);
  });

  // The level and the index range of level 0 that draw [t0, t1] in at most SERIES_POINTS.
  function lowerBound(values, t) {
    let lo = 0, hi = values.length;
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (values[mid] < t) lo = mid + 1; else hi = mid;
    }
    return lo;
  }
  function view(t0, t1) {
    const i0 = Math.max(0, lowerBound(TIME, t0) - 1);
    const i1 = Math.min(TIME.length, lowerBound(TIME, t1) + 1);
    let level = 0;
    while (level < LEVELS - 1 && (i1 - i0) / S.merge ** level > SERIES_POINTS) level++;
    return {level, i0, i1};
  }
  function seriesTrace(column, panel, v) {
    const step = S.merge ** v.level;
    const j0 = Math.floor(v.i0 / step), j1 = Math.ceil(v.i1 / step);
    const lo = low[column][v.level], hi = high[column][v.level];
    const exact = lo === hi;
    const n = Math.max(0, j1 - j0) * (exact ? 1 : 2);
    const x = new Float32Array(n), y = new Float32Array(n);
    for (let j = j0, m = 0; j < j1; j++) {
      const t = TIME[j * step];
      if (exact) {
        x[m] = t; y[m++] = hi[j];
      } else {
        x[m] = t; y[m++] = lo[j]; x[m] = t; y[m++] = hi[j];
      }
    }
    const axis = column.split("_")[0];
    const name = column === "contour_error" ? "contour error"
      : column.replace(/_error$/, " following error").replace(/_speed$/, " speed")
        .replace(/_dac_volts$/, " D/A");
    return {type: "scatter", mode: "lines", x, y, yaxis: panel ? `y${panel + 1}` : "y",
      name, line: {width: 1, color: COLORS[axis] || "#d62728"},
      hovertemplate: `%{y:.3f}<extra>${name}</extra>`};
  }
  function feedTrace() {
    const x = [], y = [];
    for (let k = 0; k < BLOCKS; k++) {
      const end = B.end[k] !== null ? B.end[k] : (k + 1 < BLOCKS ? B.start[k + 1] : last);
      x.push(B.start[k], end, null);
      y.push(B.feed[k], B.feed[k], null);
    }
    const speeds = S.panels.findIndex((p) => p.columns.includes("path_speed"));
    return {type: "scatter", mode: "lines", x, y, yaxis: `y${speeds + 1}`,
      name: "programmed feed", line: {color: "#777", dash: "dot", width: 1.5},
      hovertemplate: "%{y:.1f} mm/min<extra>programmed feed</extra>"};
  }
  const FEED = feedTrace();
  let drawn = null;
  function seriesTraces(t0, t1) {
    const v = view(t0, t1);
    const traces = [];
    S.panels.forEach((p, k) => p.columns.forEach((c) => traces.push(seriesTrace(c, k, v))));
    traces.push(FEED);
    drawn = v;
    return traces;
  }
  Plotly.newPlot(series, seriesTraces(TIME[0] || 0, last), layout, PLOT_CONFIG);
  let redrawing = false;
  series.on("plotly_relayout", (change) => {
    if (redrawing) return;
    let t0, t1;
    if (change["xaxis.autorange"]) {
      t0 = TIME[0] || 0; t1 = last;
    } else if (change["xaxis.range[0]"] !== undefined) {
      t0 = change["xaxis.range[0]"]; t1 = change["xaxis.range[1]"];
    } else if (change["xaxis.range"]) {
      [t0, t1] = change["xaxis.range"];
    } else {
      return;
    }
    const v = view(t0, t1);
    if (drawn && v.level === drawn.level && v.i0 >= drawn.i0 && v.i1 <= drawn.i1 &&
        v.level === 0) return;
    redrawing = true;
    series.layout.xaxis.range = [t0, t1];
    series.layout.xaxis.autorange = false;
    Plotly.react(series, seriesTraces(t0, t1), series.layout, PLOT_CONFIG)
      .then(() => { redrawing = false; });
  });

  // The cursor: the tool's place on the part at the time hovered, and back.
  series.on("plotly_hover", (event) => {
    if (!event.points.length || !TIME.length) return;
    const i = Math.min(TIME.length - 1, lowerBound(TIME, event.points[0].x));
    const at = {x: [[actual.x[i]]], y: [[actual.y[i]]]};
    if (threeD) at.z = [[actual.z[i]]];
    Plotly.restyle(part, at, [3]);
  });
  part.on("plotly_hover", (event) => {
    const point = event.points[0];
    if (!point || point.curveNumber !== 1 || !TIME.length) return;
    const t = TIME[point.pointNumber];
    redrawing = true;
    Plotly.relayout(series, {shapes: [{type: "line", xref: "x", yref: "paper", x0: t, x1: t,
      y0: 0, y1: 1, line: {color: "#000", width: 1}}]}).then(() => { redrawing = false; });
  });

  // -- the blocks ----------------------------------------------------------------------------
  function zoomToBlock(k) {
    const end = B.end[k] !== null ? B.end[k] : (k + 1 < BLOCKS ? B.start[k + 1] : last);
    const pad = Math.max((end - B.start[k]) * 0.1, 1e-4);
    Plotly.relayout(series, {"xaxis.range": [B.start[k] - pad, end + pad]});
    const box = {};
    const names = threeD ? ["x", "y", "z"] : ["x", "y"];
    names.forEach((a) => { box[a] = [Infinity, -Infinity]; });
    const chosen = {x: [], y: [], z: []};
    const take = (source, i, keep) => names.forEach((a) => {
      const value = source[a][i];
      if (Number.isNaN(value)) return;
      box[a][0] = Math.min(box[a][0], value);
      box[a][1] = Math.max(box[a][1], value);
      if (keep) chosen[a].push(value);
    });
    for (let i = 0; i < program.block.length; i++) if (program.block[i] === k) take(program, i, true);
    for (let i = 0; i < actual.block.length; i++) if (actual.block[i] === k) take(actual, i, false);
    Plotly.restyle(part, {x: [chosen.x], y: [chosen.y], z: [chosen.z]}, [2]);
    if (!Number.isFinite(box.x[0])) return;
    const side = Math.max(...names.map((a) => box[a][1] - box[a][0]), 1e-3);
    const range = (a) => {
      const mid = (box[a][0] + box[a][1]) / 2;
      return [mid - 0.6 * side, mid + 0.6 * side];
    };
    if (threeD) {
      Plotly.relayout(part, {"scene.xaxis.range": range("x"), "scene.yaxis.range": range("y"),
        "scene.zaxis.range": range("z"), "scene.aspectmode": "cube"});
    } else {
      Plotly.relayout(part, {"xaxis.range": range("x"), "yaxis.range": range("y")});
    }
  }
  const columns = [
    {key: "label", label: "block"}, {key: "line", label: "line"},
    {key: "index", label: "index"}, {key: "code", label: "code"}, {key: "kind", label: "kind"},
    {key: "feed", label: "feed (mm/min)", digits: 1},
    {key: "start", label: "start (s)", digits: 4},
    {key: "planned", label: "planned (s)", digits: 4},
    {key: "actual", label: "actual (s)", digits: 4},
    {key: "max", label: "max contour error (LSB)", digits: 2},
    {key: "rms", label: "RMS contour error (LSB)", digits: 2},
  ];
  sortableTable(document.getElementById("blocks"), columns, B, zoomToBlock);

  // -- the ballbar ---------------------------------------------------------------------------
  if (D.ballbar) {
    const bb = D.ballbar;
    const theta = unpack(bb.theta), deviation = unpack(bb.deviation);
    let reach = 0.5;
    deviation.forEach((v) => { reach = Math.max(reach, Math.abs(v)); });
    reach *= 1.15;
    const ring = Array.from({length: 361}, (_, k) => k);
    document.getElementById("ballbar-section").hidden = false;
    const f = bb.figures;
    Plotly.newPlot("ballbar", [
      {type: "scatterpolar", mode: "lines", r: ring.map(() => 0), theta: ring,
        name: "nominal (0)", line: {color: "#999"}, hoverinfo: "skip"},
      {type: "scatterpolar", mode: "lines", r: deviation, theta, name: "measured",
        line: {color: "#d62728", width: 1},
        hovertemplate: "%{theta:.1f} deg: %{r:+.2f} LSB<extra></extra>"},
    ], {polar: {radialaxis: {range: [-3 * reach, reach], title: {text: "radial deviation (LSB)"}}},
      title: {text: `R ${bb.radius.toFixed(0)} LSB; mean dR ${f.mean_radius_deviation.toFixed(2)}; ` +
        `circularity ${f.circularity.toFixed(2)}; 2-theta ${f.two_theta_amplitude.toFixed(2)} at ` +
        `${f.two_theta_angle.toFixed(0)} deg (LSB); ${f.ballbar_sweep.toFixed(0)} deg analysed`,
        font: {size: 13}}}, PLOT_CONFIG);
  }
  window.k37Report = {zoomToBlock, view: () => drawn};
})();
