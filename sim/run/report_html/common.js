"use strict";
// What every k37 report page shares: its data, packed arrays, numbers, a sortable table.
const K37 = JSON.parse(document.getElementById("k37-data").textContent);

// A packed array ({b64, dtype}) as a typed array.
function unpack(packed) {
  const text = atob(packed.b64);
  const bytes = new Uint8Array(text.length);
  for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i);
  return packed.dtype === "i4" ? new Int32Array(bytes.buffer) : new Float32Array(bytes.buffer);
}

// A number for a table cell: integers with thousands separators, others with `digits`.
function formatValue(value, digits) {
  if (value === null || value === undefined) return "";
  if (typeof value !== "number") return String(value);
  if (digits === undefined) return value.toLocaleString("en");
  return value.toFixed(digits);
}

// A table of `data` (an object of equal-length columns) with `columns` ([{key, label,
// digits}]): a click on a heading sorts by it (again: the other way), a click on a row calls
// onRow(row index), `render` gives a cell's HTML instead of its text.
function sortableTable(container, columns, data, onRow, render) {
  const count = columns.length ? data[columns[0].key].length : 0;
  const escape = (s) => String(s).replace(/[&<>"]/g, (c) => ({"&": "&amp;", "<": "&lt;",
    ">": "&gt;", "\"": "&quot;"}[c]));
  const head = columns.map((c, k) => `<th data-col="${k}">${escape(c.label)}</th>`).join("");
  const rows = [];
  for (let r = 0; r < count; r++) {
    const cells = columns.map((c) => {
      const value = data[c.key][r];
      return `<td>${render && render(c, r) || escape(formatValue(value, c.digits))}</td>`;
    });
    rows.push(`<tr data-row="${r}">${cells.join("")}</tr>`);
  }
  container.innerHTML = `<table><thead><tr>${head}</tr></thead><tbody>${rows.join("")}` +
    "</tbody></table>";
  const tbody = container.querySelector("tbody");
  const trs = Array.from(tbody.rows);
  let sortedBy = -1, up = true;
  container.querySelector("thead").addEventListener("click", (event) => {
    const th = event.target.closest("th");
    if (!th) return;
    const col = Number(th.dataset.col), key = columns[col].key;
    up = sortedBy === col ? !up : true;
    sortedBy = col;
    const values = data[key];
    const order = trs.slice().sort((a, b) => {
      const x = values[a.dataset.row], y = values[b.dataset.row];
      if (x === y) return a.dataset.row - b.dataset.row;
      if (x === null) return 1;
      if (y === null) return -1;
      return (x < y ? -1 : 1) * (up ? 1 : -1);
    });
    const fragment = document.createDocumentFragment();
    order.forEach((tr) => fragment.appendChild(tr));
    tbody.appendChild(fragment);
    container.querySelectorAll("th").forEach((h) => h.classList.remove("sorted-up",
      "sorted-down"));
    th.classList.add(up ? "sorted-up" : "sorted-down");
  });
  if (onRow) {
    tbody.addEventListener("click", (event) => {
      const tr = event.target.closest("tr");
      if (!tr || event.target.closest("a")) return;
      tbody.querySelectorAll("tr.selected").forEach((s) => s.classList.remove("selected"));
      tr.classList.add("selected");
      onRow(Number(tr.dataset.row));
    });
  }
}

// plotly.js's options for every figure of a page: no logo, no link to an online editor.
const PLOT_CONFIG = {displaylogo: false, responsive: true, showLink: false, showSendToCloud: false};
