"use strict";
// The report of a study: main effects, the response surface, the runs (study/html_report.py).
(function () {
  const D = K37;
  const factors = Object.keys(D.effects);
  const effects = document.getElementById("effects");
  const traces = factors.map((f, k) => ({type: "scatter", mode: "lines+markers", name: f,
    x: D.effects[f].map((p) => p[0]), y: D.effects[f].map((p) => p[1]),
    xaxis: `x${k ? k + 1 : ""}`, yaxis: "y",
    hovertemplate: `${f} = %{x}: mean ${D.metric} %{y:.4g}<extra></extra>`}));
  const layout = {margin: {l: 70, r: 20, t: 30, b: 50}, showlegend: false,
    grid: {rows: 1, columns: Math.max(1, factors.length), pattern: "independent"},
    yaxis: {title: {text: `mean ${D.metric}`}}};
  factors.forEach((f, k) => { layout[`xaxis${k ? k + 1 : ""}`] = {title: {text: f}}; });
  Plotly.newPlot(effects, traces, layout, PLOT_CONFIG);

  const text = document.getElementById("surface-text");
  const surface = D.surface;
  if (!surface) {
    text.textContent = `No response surface: ${D.needs}`;
    document.getElementById("surface").hidden = true;
  } else {
    const where = surface.stationary ? `; stationary point (${surface.kind}): ` +
      surface.factors.map((f, k) => `${f} = ${surface.stationary[k].toPrecision(4)}`)
        .join(", ") : "";
    text.textContent = `Second-order fit on coded factors, R\u00b2 = ` +
      `${surface.r_squared.toFixed(4)}${where}.`;
    if (surface.grid) {
      const [fx, fy] = surface.factors;
      const rest = surface.factors.slice(2);
      Plotly.newPlot("surface", [{type: "contour", x: surface.grid.x, y: surface.grid.y,
        z: surface.grid.z, colorscale: "Viridis", colorbar: {title: {text: D.metric}},
        hovertemplate: `${fx} %{x:.4g}, ${fy} %{y:.4g}: ${D.metric} %{z:.4g}<extra></extra>`}],
      {margin: {l: 70, r: 20, t: 30, b: 50}, xaxis: {title: {text: fx}},
        yaxis: {title: {text: fy}}, title: {text: rest.length ? `${rest.join(", ")} at the ` +
          "centre of their range" : "", font: {size: 12}}}, PLOT_CONFIG);
    } else {
      document.getElementById("surface").hidden = true;
    }
    sortableTable(document.getElementById("coefficients"),
      [{key: "term", label: "term"}, {key: "beta", label: "coefficient", digits: 5}],
      {term: surface.terms, beta: surface.coefficients});
  }

  const columns = D.columns.map((c) => ({key: c, label: c}));
  sortableTable(document.getElementById("runs"), columns, D.rows, null, (column, row) => {
    const link = D.links[row];
    return column.key === "run" && link ?
      `<a href="${encodeURI(link)}">${D.rows.run[row]}</a>` : "";
  });
})();
