/* vinecli time-series figures: draws each <div class="tsc"> of the page from its <script class="tsc-data"> JSON
   (vinecli/report/chart.py) with uPlot (vendored; nothing is fetched). A figure is a stack of plots on one time
   axis: lines (steps for commands, a right-hand axis for a twin quantity), dotted event lines, shaded check
   windows. Drag across a plot to zoom (every plot of the figure follows), double-click to zoom out; the legend
   under each plot reads the values under the cursor. */
(function () {
  "use strict";
  var figures = 0;

  function bytesOf(b64) {
    var bin = atob(b64), out = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out;
  }

  function decode(enc) {  // deflated int16/int32 differences of steps -> values (null in the gaps)
    var stream = new Blob([bytesOf(enc.d)]).stream().pipeThrough(new DecompressionStream("deflate"));
    return new Response(stream).arrayBuffer().then(function (buf) {
      var d = enc.w === 4 ? new Int32Array(buf) : new Int16Array(buf), out = new Array(d.length), q = 0;
      for (var i = 0; i < d.length; i++) { q += d[i]; out[i] = enc.lo + q * enc.step; }
      (enc.gaps || []).forEach(function (g) { for (var j = g[0]; j < g[1]; j++) out[j] = null; });
      return out;
    });
  }

  function fmt(u, v) {
    if (v == null) return "–";
    var a = Math.abs(v);
    return a >= 1000 ? v.toFixed(0) : a >= 100 ? v.toFixed(1) : a >= 1 ? v.toFixed(2) : v.toPrecision(3);
  }

  function fixed(lim) {
    return lim ? {range: function () { return lim; }} : {};
  }

  function shade(u, windows) {  // check windows under the lines: green passed, red failed
    var ctx = u.ctx, b = u.bbox;
    windows.forEach(function (w) {
      var x0 = Math.max(b.left, u.valToPos(w[0], "x", true)), x1 = Math.min(b.left + b.width, u.valToPos(w[1], "x", true));
      if (x1 <= x0) return;
      ctx.fillStyle = w[2] ? "rgba(44,160,44,0.10)" : "rgba(214,39,40,0.12)";
      ctx.fillRect(x0, b.top, x1 - x0, b.height);
    });
  }

  function marks(u, spec, panel, first) {  // the line at 0, the events, the windows' labels (on the first plot)
    var ctx = u.ctx, b = u.bbox, px = uPlot.pxRatio;
    ctx.save();
    ctx.beginPath();
    ctx.rect(b.left, b.top, b.width, b.height);
    ctx.clip();
    ctx.font = (11 * px) + "px system-ui, sans-serif";
    ctx.textAlign = "left";  // uPlot leaves the canvas right-aligned from its axes: labels would end at their line
    ctx.textBaseline = "alphabetic";
    if (panel.zero) {
      var y0 = Math.round(u.valToPos(0, "y", true));
      ctx.strokeStyle = "#999";
      ctx.lineWidth = px;
      ctx.beginPath(); ctx.moveTo(b.left, y0); ctx.lineTo(b.left + b.width, y0); ctx.stroke();
    }
    spec.events.forEach(function (e) {
      var x = Math.round(u.valToPos(e[0], "x", true));
      ctx.strokeStyle = ctx.fillStyle = e[2];
      ctx.lineWidth = 1.2 * px;
      ctx.setLineDash([2 * px, 3 * px]);
      ctx.beginPath(); ctx.moveTo(x, b.top); ctx.lineTo(x, b.top + b.height); ctx.stroke();
      ctx.setLineDash([]);
      if (e[1]) {  // right of its line, or left of it where it would run off the plot
        var right = x + 3 * px + ctx.measureText(e[1]).width > b.left + b.width;
        ctx.textAlign = right ? "right" : "left";
        ctx.fillText(e[1], right ? x - 3 * px : x + 3 * px, b.top + 12 * px);
        ctx.textAlign = "left";
      }
    });
    if (first) {
      spec.windows.forEach(function (w, i) {
        ctx.fillStyle = w[2] ? "#2ca02c" : "#d62728";
        ctx.fillText(w[3], Math.max(b.left, u.valToPos(w[0], "x", true)) + 3 * px, b.top + b.height - (4 + 13 * i) * px);
      });
    }
    ctx.restore();
  }

  function draw(root) {
    var spec = JSON.parse(root.querySelector("script.tsc-data").textContent);
    var box = root.querySelector(".tsc-plots");
    var wanted = [decode(spec.t)];
    spec.panels.forEach(function (p) { p.series.forEach(function (s) { wanted.push(decode(s.y)); }); });
    return Promise.all(wanted).then(function (cols) {
      var t = cols[0], k = 1, plots = [], syncing = false, key = "tsc-" + (figures++);
      var width = Math.max(280, box.clientWidth);
      spec.panels.forEach(function (p, pi) {
        var last = pi === spec.panels.length - 1, data = [t], right = false;
        var series = [{label: spec.xlabel, value: fmt}];
        p.series.forEach(function (s) {
          data.push(cols[k++]);
          right = right || s.right;
          series.push({label: s.label, stroke: s.color, width: s.width, dash: s.dash.length ? s.dash : undefined,
                       scale: s.right ? "y2" : "y", paths: s.step ? uPlot.paths.stepped({align: 1}) : undefined,
                       value: fmt, points: {show: false}});
        });
        var scales = {x: {time: false}, y: fixed(p.ylim)};
        var axes = [{label: last ? spec.xlabel : "", size: last ? 40 : 28, labelSize: last ? 18 : 0},
                    {scale: "y", label: p.ylabel, size: 58, labelSize: 20}];
        if (right) {
          scales.y2 = fixed(p.y2lim);
          axes.push({scale: "y2", side: 1, label: p.y2label, size: 58, labelSize: 20, grid: {show: false}});
        }
        var el = document.createElement("div");
        el.className = "tsc-plot";
        box.appendChild(el);
        plots.push(new uPlot({
          width: width, height: p.height, series: series, scales: scales, axes: axes,
          cursor: {sync: {key: key}, drag: {x: true, y: false}},
          hooks: {
            drawClear: [function (u) { shade(u, spec.windows); }],
            draw: [function (u) { marks(u, spec, p, pi === 0); }],
            setScale: [function (u, sk) {  // a zoom on one plot zooms them all
              if (sk !== "x" || syncing) return;
              syncing = true;
              plots.forEach(function (o) { if (o !== u) o.setScale("x", {min: u.scales.x.min, max: u.scales.x.max}); });
              syncing = false;
            }]
          }
        }, data, el));
      });
      if (window.ResizeObserver) {
        new ResizeObserver(function () {
          var w = Math.max(280, box.clientWidth);
          plots.forEach(function (u) { if (Math.abs(u.width - w) > 2) u.setSize({width: w, height: u.height}); });
        }).observe(box);
      }
      root.charts = plots;  // the uPlot instances (scripts and tests read their scales)
      root.dataset.ready = "1";
    });
  }

  function start() { Array.prototype.forEach.call(document.querySelectorAll("div.tsc"), draw); }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start); else start();
})();
