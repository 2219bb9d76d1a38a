// The rollout viewer: a Canvas-2D renderer with its own orthographic projection and painter's sort.
// Data: the JSON in <script id="rollout">. URL hash: #step=N&yaw=RAD&pitch=RAD selects a view.
// The body's data-status is "loading", then "ok" after the first frame, or "error: …" on any error.
"use strict";
window.onerror = function (message, source, line) {
  document.body.setAttribute("data-status", "error: " + message + " (line " + line + ")");
};
(function () {
  const data = JSON.parse(document.getElementById("rollout").textContent);
  const canvas = document.getElementById("view");
  const ctx = canvas.getContext("2d");
  const slider = document.getElementById("slider");
  const playButton = document.getElementById("play");
  const stepLabel = document.getElementById("step");
  const info = document.getElementById("info");
  const last = data.states.length - 1;
  const cam = { yaw: 0.9, pitch: 0.5, zoom: 1 };
  let step = 0;
  let timer = null;
  slider.max = String(last);

  // Everything drawn fits the view at zoom 1, whatever the direction.
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  const grow = (p, r) => {
    for (let k = 0; k < 3; k++) {
      lo[k] = Math.min(lo[k], p[k] - r);
      hi[k] = Math.max(hi[k], p[k] + r);
    }
  };
  data.states.forEach((s) => s.forEach((p) => grow(p, 0)));
  data.spheres.forEach((s) => grow(s.center, s.radius + (data.safety_margin || 0)));
  data.solids.forEach((s) => s.vertices.forEach((p) => grow(p, 0)));
  data.targets.forEach((p) => grow(p, 0));
  if (data.ground_z !== null) {
    lo[2] = Math.min(lo[2], data.ground_z);
    hi[2] = Math.max(hi[2], data.ground_z);
  }
  const centre = [0, 1, 2].map((k) => (lo[k] + hi[k]) / 2);
  const extent = Math.max(1e-9, 0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]));

  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const cross = (a, b) => [
    a[1] * b[2] - a[2] * b[1],
    a[2] * b[0] - a[0] * b[2],
    a[0] * b[1] - a[1] * b[0],
  ];
  const LIGHT = (() => {
    const l = [-0.3, -0.5, 0.8];
    const n = Math.hypot(l[0], l[1], l[2]);
    return l.map((v) => v / n);
  })();

  // Camera: `eye` points from the scene to the camera (yaw about z, pitch above the horizon);
  // `right` and `up` span the screen. Depth grows away from the camera.
  function camera(width, height) {
    const cy = Math.cos(cam.yaw), sy = Math.sin(cam.yaw);
    const cp = Math.cos(cam.pitch), sp = Math.sin(cam.pitch);
    const right = [cy, sy, 0];
    const up = [-sy * sp, cy * sp, cp];
    const eye = [sy * cp, -cy * cp, sp];
    const scale = (cam.zoom * 0.45 * Math.min(width, height)) / extent;
    return {
      scale,
      eye,
      px(p) {
        const d = sub(p, centre);
        return [width / 2 + scale * dot(d, right), height / 2 - scale * dot(d, up)];
      },
      depth(p) {
        return -dot(sub(p, centre), eye);
      },
    };
  }

  const rgba = (c, a) => "rgba(" + c[0] + "," + c[1] + "," + c[2] + "," + a + ")";
  // Flat shading: either side lit alike, so the winding does not matter.
  function shade(c, a, b, d) {
    const n = cross(sub(b, a), sub(d, a));
    const len = Math.hypot(n[0], n[1], n[2]);
    const lit = len > 0 ? Math.abs(dot(n, LIGHT)) / len : 0;
    const k = 0.55 + 0.45 * lit;
    return [Math.round(c[0] * k), Math.round(c[1] * k), Math.round(c[2] * k)];
  }
  const CLOTH = [31, 119, 180];
  const PATHS = [[128, 0, 170], [0, 150, 60], [0, 90, 200], [200, 100, 0]];
  const SOLIDS = { safety: [150, 165, 200], collider: [200, 160, 110], both: [170, 170, 175] };

  function draw() {
    const ratio = window.devicePixelRatio || 1;
    const width = canvas.clientWidth, height = canvas.clientHeight;
    if (canvas.width !== Math.round(width * ratio) || canvas.height !== Math.round(height * ratio)) {
      canvas.width = Math.round(width * ratio);
      canvas.height = Math.round(height * ratio);
    }
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    ctx.fillStyle = "#ffffff";
    ctx.fillRect(0, 0, width, height);
    const cam3 = camera(width, height);
    const state = data.states[step];

    // The ground first: everything stands on it.
    if (data.ground_z !== null) {
      const z = data.ground_z;
      const quad = [[lo[0], lo[1], z], [hi[0], lo[1], z], [hi[0], hi[1], z], [lo[0], hi[1], z]];
      polygon(quad.map(cam3.px), "rgba(205,185,150,0.45)", null);
    }

    // Depth-sorted primitives, farthest first (painter's algorithm).
    const items = [];
    for (const t of data.triangles) {
      const [a, b, c] = [state[t[0]], state[t[1]], state[t[2]]];
      const mid = [0, 1, 2].map((k) => (a[k] + b[k] + c[k]) / 3);
      items.push({ depth: cam3.depth(mid), kind: "cloth", pts: [a, b, c], color: shade(CLOTH, a, b, c) });
    }
    for (const s of data.spheres) {
      items.push({ depth: cam3.depth(s.center), kind: "sphere", sphere: s });
    }
    for (const solid of data.solids) {
      const base = SOLIDS[solid.role];
      for (const t of solid.triangles) {
        const [a, b, c] = [solid.vertices[t[0]], solid.vertices[t[1]], solid.vertices[t[2]]];
        const mid = [0, 1, 2].map((k) => (a[k] + b[k] + c[k]) / 3);
        items.push({ depth: cam3.depth(mid), kind: "solid", pts: [a, b, c], color: shade(base, a, b, c) });
      }
    }
    data.control_particles.forEach((p, k) => {
      const color = PATHS[k % PATHS.length];
      for (let t = 0; t < last; t++) {
        const a = data.states[t][p], b = data.states[t + 1][p];
        const mid = [0, 1, 2].map((i) => (a[i] + b[i]) / 2);
        items.push({ depth: cam3.depth(mid), kind: "segment", a, b, color, width: t < step ? 4 : 2 });
      }
      items.push({ depth: cam3.depth(state[p]) - 1e-6, kind: "marker", at: state[p], color });
    });
    items.sort((x, y) => y.depth - x.depth);
    for (const it of items) {
      if (it.kind === "cloth") {
        polygon(it.pts.map(cam3.px), rgba(it.color, 0.55), rgba(CLOTH, 0.9));
      } else if (it.kind === "solid") {
        const fill = rgba(it.color, 1);
        polygon(it.pts.map(cam3.px), fill, fill);
      } else if (it.kind === "sphere") {
        const [x, y] = cam3.px(it.sphere.center);
        const r = Math.max(2, it.sphere.radius * cam3.scale);
        const g = ctx.createRadialGradient(x - 0.35 * r, y - 0.35 * r, 0.1 * r, x, y, r);
        g.addColorStop(0, "rgb(238,238,242)");
        g.addColorStop(1, "rgb(105,110,125)");
        disc(x, y, r, g, "rgb(60,60,70)");
      } else if (it.kind === "segment") {
        line(cam3.px(it.a), cam3.px(it.b), rgba(it.color, 1), it.width, []);
      } else {
        const [x, y] = cam3.px(it.at);
        disc(x, y, 6, rgba(it.color, 1), "#000");
      }
    }

    // Overlays, always on top: the safety margin, targets, the closest particle.
    const margin = data.safety_margin;
    if (margin !== null) {
      for (const s of data.spheres) {
        const [x, y] = cam3.px(s.center);
        ctx.beginPath();
        ctx.arc(x, y, (s.radius + margin) * cam3.scale, 0, 2 * Math.PI);
        ctx.setLineDash([5, 4]);
        ctx.strokeStyle = "rgb(200,40,40)";
        ctx.lineWidth = 1;
        ctx.stroke();
        ctx.setLineDash([]);
      }
    }
    for (const p of data.target_particles) {
      const [x, y] = cam3.px(state[p]);
      ring(x, y, 7, "rgb(225,20,20)", 2);
    }
    for (const t of data.targets) {
      const [x, y] = cam3.px(t);
      disc(x, y, 5, "rgb(225,20,20)", "#000");
    }
    let closestText = "";
    const closest = data.closest.length > step ? data.closest[step] : null;
    if (closest !== null) {
      const [x, y] = cam3.px(state[closest.particle]);
      const unsafe = margin !== null && closest.distance < margin;
      const color = unsafe ? "rgb(220,0,0)" : "rgb(255,140,0)";
      ring(x, y, 11, color, 3);
      ctx.fillStyle = color;
      ctx.font = "bold 13px sans-serif";
      ctx.fillText(closest.distance.toFixed(3) + " m", x + 14, y - 8);
      closestText =
        "closest to the obstacles: particle " + closest.particle + " at " + closest.distance.toFixed(4) + " m" +
        (margin !== null ? (unsafe ? " — inside the margin δ = " : " (margin δ = ") + margin + (unsafe ? "" : ")") : "");
    }
    info.textContent = "";
    const title = document.createElement("b");
    title.textContent = data.title;
    info.appendChild(title);
    const line2 = document.createElement("div");
    line2.textContent = "step " + step + " of " + last + (closestText ? " · " + closestText : "");
    info.appendChild(line2);
    stepLabel.textContent = "step " + step + " / " + last;
    slider.value = String(step);
    document.body.setAttribute("data-step", String(step));
  }

  function polygon(pts, fill, stroke) {
    ctx.beginPath();
    ctx.moveTo(pts[0][0], pts[0][1]);
    for (let i = 1; i < pts.length; i++) ctx.lineTo(pts[i][0], pts[i][1]);
    ctx.closePath();
    ctx.fillStyle = fill;
    ctx.fill();
    if (stroke) {
      ctx.strokeStyle = stroke;
      ctx.lineWidth = 0.6;
      ctx.stroke();
    }
  }
  function line(a, b, color, width, dash) {
    ctx.beginPath();
    ctx.moveTo(a[0], a[1]);
    ctx.lineTo(b[0], b[1]);
    ctx.setLineDash(dash);
    ctx.strokeStyle = color;
    ctx.lineWidth = width;
    ctx.stroke();
    ctx.setLineDash([]);
  }
  function disc(x, y, r, fill, stroke) {
    ctx.beginPath();
    ctx.arc(x, y, r, 0, 2 * Math.PI);
    ctx.fillStyle = fill;
    ctx.fill();
    ctx.strokeStyle = stroke;
    ctx.lineWidth = 1;
    ctx.stroke();
  }
  function ring(x, y, r, color, width) {
    ctx.beginPath();
    ctx.arc(x, y, r, 0, 2 * Math.PI);
    ctx.strokeStyle = color;
    ctx.lineWidth = width;
    ctx.stroke();
  }

  function setStep(t) {
    step = Math.max(0, Math.min(last, t));
    draw();
  }
  function stop() {
    if (timer !== null) clearInterval(timer);
    timer = null;
    playButton.textContent = "Play";
  }
  playButton.addEventListener("click", () => {
    if (timer !== null) return stop();
    if (step >= last) setStep(0);
    playButton.textContent = "Pause";
    timer = setInterval(() => (step >= last ? stop() : setStep(step + 1)), 250);
  });
  slider.addEventListener("input", () => {
    stop();
    setStep(Number(slider.value));
  });

  // Orbit with the mouse (drag), zoom with the wheel.
  let drag = null;
  canvas.addEventListener("pointerdown", (e) => {
    drag = { x: e.clientX, y: e.clientY };
    canvas.setPointerCapture(e.pointerId);
  });
  canvas.addEventListener("pointermove", (e) => {
    if (drag === null) return;
    cam.yaw -= 0.01 * (e.clientX - drag.x);
    cam.pitch = Math.max(-1.55, Math.min(1.55, cam.pitch + 0.01 * (e.clientY - drag.y)));
    drag = { x: e.clientX, y: e.clientY };
    draw();
  });
  canvas.addEventListener("pointerup", () => (drag = null));
  canvas.addEventListener(
    "wheel",
    (e) => {
      e.preventDefault();
      cam.zoom = Math.max(0.1, Math.min(20, cam.zoom * Math.exp(-0.001 * e.deltaY)));
      draw();
    },
    { passive: false },
  );

  function readHash() {
    const params = new URLSearchParams(window.location.hash.slice(1));
    const num = (key) => {
      const v = params.get(key);
      return v === null || v === "" || !isFinite(Number(v)) ? null : Number(v);
    };
    if (num("yaw") !== null) cam.yaw = num("yaw");
    if (num("pitch") !== null) cam.pitch = num("pitch");
    setStep(num("step") !== null ? Math.round(num("step")) : step);
  }
  window.addEventListener("hashchange", readHash);
  window.addEventListener("resize", draw);
  readHash();
  if (!document.body.getAttribute("data-status").startsWith("error")) {
    document.body.setAttribute("data-status", "ok");
  }
})();
