// Waymark report: pan (drag), zoom (wheel, +/- buttons; double-click resets)
// and hover details (elements with data-info) for each map on the page. The
// project's own script, inline; it loads nothing.
(function () {
  "use strict";
  document.querySelectorAll(".map-box").forEach(function (box) {
    var svg = box.querySelector("svg.wm-map");
    if (!svg) return;
    var tip = box.querySelector(".map-tip");
    var vb0 = svg.getAttribute("viewBox").split(" ").map(Number);
    var vb = vb0.slice();
    var bar = box.parentNode.querySelector(".scale-bar");
    function scaleBar() {
      if (!bar) return;
      var px = svg.getBoundingClientRect().width || 1;
      var mPerPx = vb[2] / px;
      var target = 120 * mPerPx, mag = Math.pow(10, Math.floor(Math.log10(target)));
      var len = mag;
      [1, 2, 5].forEach(function (k) { if (k * mag <= target) len = k * mag; });
      bar.querySelector(".bar").style.width = (len / mPerPx).toFixed(0) + "px";
      bar.querySelector(".len").textContent = len >= 1000 ? len / 1000 + " km" : len + " m";
    }
    function apply() { svg.setAttribute("viewBox", vb.map(function (v) { return v.toFixed(1); }).join(" ")); scaleBar(); }
    function toMap(ev) {
      var r = svg.getBoundingClientRect();
      return [vb[0] + (ev.clientX - r.left) / r.width * vb[2], vb[1] + (ev.clientY - r.top) / r.height * vb[3]];
    }
    function zoom(f, at) {
      var w = Math.min(Math.max(vb[2] * f, vb0[2] / 200), vb0[2] * 6), k = w / vb[2];
      vb = [at[0] - (at[0] - vb[0]) * k, at[1] - (at[1] - vb[1]) * k, w, vb[3] * k];
      apply();
    }
    svg.addEventListener("wheel", function (ev) {
      ev.preventDefault();
      zoom(ev.deltaY > 0 ? 1.25 : 0.8, toMap(ev));
    }, { passive: false });
    var drag = null;
    svg.addEventListener("pointerdown", function (ev) { drag = [ev.clientX, ev.clientY, vb[0], vb[1]]; });
    window.addEventListener("pointerup", function () { drag = null; });
    svg.addEventListener("pointermove", function (ev) {
      if (drag) {
        var r = svg.getBoundingClientRect();
        vb[0] = drag[2] - (ev.clientX - drag[0]) / r.width * vb[2];
        vb[1] = drag[3] - (ev.clientY - drag[1]) / r.height * vb[3];
        apply();
        return;
      }
      var t = ev.target.closest ? ev.target.closest("[data-info]") : null;
      if (t && tip) {
        var b = box.getBoundingClientRect();
        tip.textContent = t.getAttribute("data-info");
        tip.style.left = (ev.clientX - b.left + 12) + "px";
        tip.style.top = (ev.clientY - b.top + 12) + "px";
        tip.style.display = "block";
      } else if (tip) {
        tip.style.display = "none";
      }
    });
    svg.addEventListener("pointerleave", function () { if (tip) tip.style.display = "none"; });
    svg.addEventListener("dblclick", function () { vb = vb0.slice(); apply(); });
    box.querySelectorAll("button[data-zoom]").forEach(function (b) {
      b.addEventListener("click", function () {
        var f = b.getAttribute("data-zoom");
        if (f === "reset") { vb = vb0.slice(); apply(); return; }
        zoom(Number(f), [vb[0] + vb[2] / 2, vb[1] + vb[3] / 2]);
      });
    });
    window.addEventListener("resize", scaleBar);
    scaleBar();
  });
  document.body.setAttribute("data-map-script", "ready");
})();
