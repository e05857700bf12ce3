/* inspect-validate: draws each <div class="chart"> of a report from the JSON beside it,
   with uPlot (embedded above this script). A spec: {title, xlabel, ylabel, logx, logy, xrange, yrange,
   vlines: [{x, label}], hband: [lo, hi], zero, series: [{label, color, x, y | xref, kind:
   "line" | "step" | "points", dash, width, fill, hollow, hidden}], bands: [[hi, lo, fill]]}.
   Every series keeps its own x values: the chart's x axis holds them all, sorted, each
   slot one series' point (a series with xref shares the slots of the series it names). */
(function () {
  "use strict";

  function aligned(spec) {
    var slots = [];
    spec.series.forEach(function (s, i) {
      if (s.xref === undefined) {
        s.x.forEach(function (x, j) { slots.push([x, i, j]); });
      }
    });
    slots.sort(function (a, b) { return a[0] - b[0]; });
    var xs = slots.map(function (s) { return s[0]; });
    var columns = spec.series.map(function () { return new Array(slots.length).fill(null); });
    slots.forEach(function (slot, k) {
      var owner = slot[1], j = slot[2];
      spec.series.forEach(function (s, i) {
        if (i === owner || s.xref === owner) {
          var v = s.y[j];
          columns[i][k] = (v === null || v === undefined || !isFinite(v)) ? null : v;
        }
      });
    });
    return [xs].concat(columns);
  }

  function decorate(spec) {
    return function (u) {
      var ctx = u.ctx, box = u.bbox;
      ctx.save();
      if (spec.hband) {
        var top = u.valToPos(spec.hband[1], "y", true), bottom = u.valToPos(spec.hband[0], "y", true);
        ctx.fillStyle = "rgba(44, 160, 44, 0.15)";
        ctx.fillRect(box.left, Math.min(top, bottom), box.width, Math.abs(bottom - top));
      }
      if (spec.zero) {
        var y0 = u.valToPos(0, "y", true);
        ctx.strokeStyle = "#666";
        ctx.lineWidth = 1;
        ctx.beginPath(); ctx.moveTo(box.left, y0); ctx.lineTo(box.left + box.width, y0); ctx.stroke();
      }
      (spec.vlines || []).forEach(function (line, k) {
        var x = u.valToPos(line.x, "x", true);
        if (x < box.left || x > box.left + box.width) { return; }
        ctx.strokeStyle = "#555";
        ctx.setLineDash([2, 3]);
        ctx.beginPath(); ctx.moveTo(x, box.top); ctx.lineTo(x, box.top + box.height); ctx.stroke();
        ctx.setLineDash([]);
        ctx.fillStyle = "#333";
        ctx.font = Math.round(11 * devicePixelRatio) + "px sans-serif";
        ctx.textAlign = "center";
        ctx.fillText(line.label, x, box.top + (12 + 12 * (k % 2)) * devicePixelRatio);
      });
      ctx.restore();
    };
  }

  // Off the chart the legend shows the labels alone (uPlot's "--" read as unfinished in
  // a print or a screenshot); on it, each series' value at the cursor.
  function shown(u, v) { return v === null || v === undefined ? "" : String(+v.toPrecision(4)); }

  function options(spec, width) {
    var series = [{ label: spec.xlabel, value: shown }];
    spec.series.forEach(function (s) {
      var one = {
        label: s.label,
        stroke: s.color,
        width: s.width || 1.5,
        spanGaps: true,
        show: !s.hidden
      };
      one.value = shown;
      if (s.dash) { one.dash = [6, 4]; }
      if (s.fill) { one.fill = s.fill; }
      if (s.kind === "step") { one.paths = uPlot.paths.stepped({ align: 1 }); }
      if (s.kind === "points") {
        one.paths = function () { return null; };
        one.points = { show: true, size: 8, width: 1.5, stroke: s.color, fill: s.hollow ? "#fff" : s.color };
      } else {
        one.points = { show: false };
      }
      series.push(one);
    });
    var x = { time: false }, y = {};
    if (spec.xrange) { x.range = function () { return spec.xrange; }; }
    if (spec.logx) { x.distr = 3; }
    if (spec.logy) { y.distr = 3; }
    if (spec.yrange) { y.range = function () { return spec.yrange; }; }
    return {
      title: spec.title,
      width: width,
      height: spec.height || 320,
      scales: { x: x, y: y },
      // Whole steps only on an axis of cycles (0.5 of a cycle means nothing).
      axes: [{ label: spec.xlabel, incrs: spec.xinteger ? [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 1e4, 2e4, 5e4, 1e5, 1e6] : undefined }, {
        label: spec.ylabel,
        size: 70,
        // A log axis down to 1e-16: uPlot's own labels print every tick below 0.001 as 0.
        values: spec.logy ? function (u, ticks) {
          return ticks.map(function (v) { return v === null ? "" : (v < 1e-3 ? v.toExponential(0) : String(v)); });
        } : undefined
      }],
      series: series,
      bands: (spec.bands || []).map(function (b) { return { series: [b[0] + 1, b[1] + 1], fill: b[2] }; }),
      cursor: { drag: { x: true, y: false, setScale: true } },
      hooks: { draw: [decorate(spec)] }
    };
  }

  function draw() {
    document.querySelectorAll("div.chart").forEach(function (div) {
      var spec = JSON.parse(div.querySelector("script").textContent);
      var width = Math.max(320, Math.min(div.parentNode.clientWidth || 900, spec.width || 900));
      div.chart = new uPlot(options(spec, width), aligned(spec), div);
    });
  }

  if (document.readyState === "loading") {
    document.addEventListener("DOMContentLoaded", draw);
  } else {
    draw();
  }
})();
