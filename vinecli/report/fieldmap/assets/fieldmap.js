/* vinecli field map: draws each <div class="fm"> of the page from its <script class="fm-data"> JSON with Leaflet
   (vendored; nothing is fetched). Layers: image overlays (rasters, with hover values) and GeoJSON (vectors, with
   hover texts), a layer panel with legends, a readout of the values under the cursor, and links from failed checks
   to their place on the map (a.fm-focus[data-map][data-check]). */
(function () {
  "use strict";
  var NO_VALUE = 65535;

  function bytesOf(b64) {
    var bin = atob(b64), out = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out;
  }

  function inflate(b64) {  // deflated little-endian uint16 -> Uint16Array
    var stream = new Blob([bytesOf(b64)]).stream().pipeThrough(new DecompressionStream("deflate"));
    return new Response(stream).arrayBuffer().then(function (buf) { return new Uint16Array(buf); });
  }

  function text(s) {  // hover texts come from run files: text nodes, never HTML
    var el = document.createElement("span");
    el.textContent = s;
    return el;
  }

  function styleOf(spec, f) {
    var s = {}, k;
    for (k in spec.style) s[k] = spec.style[k];
    var own = (f && f.properties && f.properties.style) || {};
    for (k in own) s[k] = own[k];
    return s;
  }

  function legendOf(spec) {
    var box = document.createElement("div");
    box.className = "fm-legend";
    var lg = spec.legend;
    if (!lg) return box;
    (lg.swatches || []).forEach(function (sw) {
      var row = document.createElement("div"), mark = document.createElement("i");
      mark.className = "fm-sw fm-sw-" + sw[2];
      mark.style.setProperty("--c", sw[0]);
      row.appendChild(mark);
      row.appendChild(text(sw[1]));
      box.appendChild(row);
    });
    if (lg.scale && lg.scale.length) {
      var bar = document.createElement("div");
      bar.className = "fm-scale";
      bar.style.background = "linear-gradient(to right," + lg.scale.join(",") + ")";
      var ticks = document.createElement("div");
      ticks.className = "fm-ticks";
      lg.ticks.forEach(function (t) {
        var tk = text(t[1]);
        tk.style.left = (100 * t[0]) + "%";
        tk.className = t[0] > 0.9 ? "fm-tick fm-tick-end" : "fm-tick";
        ticks.appendChild(tk);
      });
      box.appendChild(bar);
      box.appendChild(ticks);
      if (lg.unit) box.appendChild(text(lg.unit)).className = "fm-unit";
    }
    return box;
  }

  function valueAt(map, r, latlng) {
    var v = r.spec.raster.values, b = r.spec.raster.bounds;
    if (!r.values || !map.hasLayer(r.group)) return null;
    var z = map.getZoom(), p = map.project(latlng, z);
    var nw = map.project([b[1][0], b[0][1]], z), se = map.project([b[0][0], b[1][1]], z);
    var fx = (p.x - nw.x) / (se.x - nw.x), fy = (p.y - nw.y) / (se.y - nw.y);
    if (!(fx >= 0 && fx < 1 && fy >= 0 && fy < 1)) return null;
    var q = r.values[Math.floor(fy * v.h) * v.w + Math.floor(fx * v.w)];
    return q === NO_VALUE ? null : v.offset + q * v.step;
  }

  function describe(r, val) {
    var x = r.spec.raster;
    if (Math.abs(val) < 0.5 * Math.pow(10, -x.digits)) val = 0;  // no "-0.00"
    var s = x.label + " " + val.toFixed(x.digits) + " " + x.unit;
    if (x.ref) s += " (" + (val / x.ref).toFixed(2) + "× " + x.ref_label + ")";
    return s;
  }

  var shared = null;
  function unshared(s) {  // "@key": a string several maps of the page share, written once (#fm-shared)
    if (typeof s !== "string" || s.charAt(0) !== "@") return s;
    if (shared === null) {
      var el = document.getElementById("fm-shared");
      shared = el ? JSON.parse(el.textContent) : {};
    }
    return shared[s.slice(1)];
  }

  function initMap(root) {
    var data = JSON.parse(root.querySelector("script.fm-data").textContent);
    data.layers.forEach(function (spec) {
      if (!spec.raster) return;
      spec.raster.png = unshared(spec.raster.png);
      if (spec.raster.values) spec.raster.values.deflated = unshared(spec.raster.values.deflated);
    });
    var el = root.querySelector(".fm-map");
    var aspect = data.aspect || 0.75;
    el.style.height = Math.round(Math.max(320, Math.min(el.clientWidth * aspect, 0.8 * window.innerHeight, 760))) + "px";
    var map = L.map(el, {zoomSnap: 0.25, maxZoom: 24, scrollWheelZoom: false});
    map.attributionControl.setPrefix("Leaflet");
    map.on("click", function () { map.scrollWheelZoom.enable(); });
    map.on("mouseout", function () { map.scrollWheelZoom.disable(); });
    if (data.basemap) L.tileLayer(data.basemap, {maxNativeZoom: 19, maxZoom: 24}).addTo(map);
    map.fitBounds(data.view);
    L.control.scale({imperial: false}).addTo(map);
    var panel = root.querySelector(".fm-layers"), rasters = [], groups = {}, pending = [];
    data.layers.forEach(function (spec) {
      var group;
      if (spec.raster) {
        group = L.imageOverlay(spec.raster.png, spec.raster.bounds, {className: "fm-raster fm-raster-" + spec.key});
        var r = {spec: spec, group: group, values: null};
        if (spec.raster.values) pending.push(inflate(spec.raster.values.deflated).then(function (v) { r.values = v; }));
        rasters.push(r);
      } else {
        group = L.geoJSON(spec.features, {
          style: function (f) { return styleOf(spec, f); },
          pointToLayer: function (f, ll) { return L.circleMarker(ll, styleOf(spec, f)); },
          onEachFeature: function (f, lyr) {
            if (f.properties.tip) lyr.bindTooltip(text(f.properties.tip), {sticky: true});
            if (f.geometry.type !== "Point") {  // a hovered line or area stands out
              lyr.on("mouseover", function () { lyr.setStyle({weight: (styleOf(spec, f).weight || 3) + 3}); });
              lyr.on("mouseout", function () { group.resetStyle(lyr); });
            }
          }
        });
      }
      groups[spec.key] = group;
      if (spec.visible) group.addTo(map);
      var entry = document.createElement("div"), label = document.createElement("label");
      var box = document.createElement("input");
      entry.className = "fm-layer";
      entry.dataset.layer = spec.key;
      box.type = "checkbox";
      box.checked = !!spec.visible;
      box.addEventListener("change", function () {
        if (box.checked) group.addTo(map); else map.removeLayer(group);
        if (group.bringToFront && box.checked) keepOrder();
      });
      label.appendChild(box);
      label.appendChild(text(" " + spec.name));
      entry.appendChild(label);
      if (spec.note) entry.appendChild(text(spec.note)).className = "fm-hint";
      entry.appendChild(legendOf(spec));
      panel.appendChild(entry);
    });
    function keepOrder() {  // vectors stay in the order of the data (a toggled layer would otherwise go on top)
      data.layers.forEach(function (spec) {
        var g = groups[spec.key];
        if (!spec.raster && map.hasLayer(g)) g.bringToFront();
      });
    }
    var readout = root.querySelector(".fm-readout"), hint = readout.textContent;
    map.on("mousemove", function (e) {
      var parts = [];
      for (var i = rasters.length - 1; i >= 0; i--) {
        var val = valueAt(map, rasters[i], e.latlng);
        if (val !== null) parts.push(describe(rasters[i], val));
      }
      parts.push(e.latlng.lat.toFixed(6) + ", " + e.latlng.lng.toFixed(6));
      readout.textContent = parts.join(" · ");
    });
    map.on("mouseout", function () { readout.textContent = hint; });
    root.fieldmap = {map: map, groups: groups, data: data};
    Promise.all(pending).then(function () { root.dataset.ready = "1"; });
  }

  function focusCheck(a) {
    var root = document.getElementById("map-" + a.dataset.map);
    if (!root || !root.fieldmap) return;
    var fm = root.fieldmap, failed = fm.groups.failed;
    if (!failed) return;
    if (!fm.map.hasLayer(failed)) failed.addTo(fm.map);
    var box = root.querySelector('.fm-layer[data-layer="failed"] input');
    if (box) box.checked = true;
    var hits = [];
    failed.eachLayer(function (l) { if (l.feature.properties.check === a.dataset.check) hits.push(l); });
    if (!hits.length) return;
    root.scrollIntoView({behavior: "smooth", block: "center"});
    fm.map.fitBounds(L.featureGroup(hits).getBounds(), {maxZoom: 21, padding: [30, 30]});
    hits.forEach(function (l) {
      var p = l.getElement && l.getElement();
      if (p) { p.classList.remove("fm-flash"); void p.getBoundingClientRect(); p.classList.add("fm-flash"); }
    });
    hits[0].openTooltip();
  }

  document.addEventListener("click", function (e) {
    var a = e.target.closest && e.target.closest("a.fm-focus");
    if (a) { e.preventDefault(); focusCheck(a); }
  });

  function start() { Array.prototype.forEach.call(document.querySelectorAll("div.fm"), initMap); }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start); else start();
})();
