/* The 3D viewer of a packmesh comparison report (report.html): the meshes of one case side by
 * side, rotated by dragging, zoomed by the wheel (shift-drag pans), coloured by a quality
 * measure, methods shown or hidden, and a click on a triangle shows its values.
 *
 * packmesh writes this file into the study's viewer/ folder beside three.js (copied from the
 * system's libjs-three with its licence) and one data file per case, viewer/mesh_CASE.js, which
 * adds {name, flat, colour_max, methods: [{label, run, nodes, tets, xyz, tri, values}]} to
 * window.PM_VIEWER.cases. Everything is loaded by <script> tags, so the report works offline,
 * from file://, out of the one folder.
 *
 * Colours follow the report's pictures: ColorBrewer's RdYlBu from blue (ideal) to red, R/l_min
 * on a log scale from 0.577 to the study's colour_max, the radius ratio from 1 down to 0.5,
 * the smallest angle from 60 down to 20 degrees.
 */
(function () {
  "use strict";
  var root = document.getElementById("pm-viewer");
  var data = window.PM_VIEWER;
  if (!root || !data || !data.cases || !data.cases.length || !window.THREE) return;
  var THREE = window.THREE;

  var MEASURES = [
    {key: "aspect_ratio", label: "R/l_min (circumradius / shortest edge)",
     t: function (v, top) { return Math.log(Math.max(v, 0.57735) / 0.57735) / Math.log(top / 0.57735); },
     legend: function (top) { return "blue 0.577 (equilateral) to red " + top + " and above"; }},
    {key: "radius_ratio", label: "radius ratio 2r/R",
     t: function (v) { return (1 - v) / 0.5; },
     legend: function () { return "blue 1 (equilateral) to red 0.5 and below"; }},
    {key: "min_angle_deg", label: "smallest angle (degrees)",
     t: function (v) { return (60 - v) / 40; },
     legend: function () { return "blue 60 to red 20 and below"; }}
  ];
  var STOPS = [[0x45, 0x75, 0xb4], [0x91, 0xbf, 0xdb], [0xe0, 0xf3, 0xf8], [0xff, 0xff, 0xbf],
               [0xfe, 0xe0, 0x90], [0xfc, 0x8d, 0x59], [0xd7, 0x30, 0x27]];

  function colour(t, out, at) {
    if (!(t > 0)) t = 0;
    if (t > 1) t = 1;
    var s = t * 6, k = Math.min(5, Math.floor(s)), f = s - k;
    for (var c = 0; c < 3; ++c) out[at + c] = ((1 - f) * STOPS[k][c] + f * STOPS[k + 1][c]) / 255;
  }

  function el(tag, attrs, text) {
    var e = document.createElement(tag);
    for (var a in attrs) e.setAttribute(a, attrs[a]);
    if (text) e.textContent = text;
    return e;
  }

  /* ---- the page's controls ---- */
  var bar = el("div", {"class": "pm-viewer-controls"});
  var caseSel = el("select", {"id": "pm-viewer-case", "aria-label": "case"});
  data.cases.forEach(function (c, i) { caseSel.appendChild(el("option", {value: i}, c.name)); });
  var measureSel = el("select", {"id": "pm-viewer-measure", "aria-label": "colour by"});
  MEASURES.forEach(function (m, i) { measureSel.appendChild(el("option", {value: i}, m.label)); });
  var methodBox = el("span", {"id": "pm-viewer-methods"});
  bar.appendChild(document.createTextNode("case "));
  bar.appendChild(caseSel);
  bar.appendChild(document.createTextNode(" colour by "));
  bar.appendChild(measureSel);
  bar.appendChild(document.createTextNode(" methods "));
  bar.appendChild(methodBox);
  var canvas = el("canvas", {"id": "pm-viewer-canvas", width: 960, height: 540});
  canvas.style.cssText = "width:100%;max-width:960px;border:1px solid #ccc;cursor:grab;touch-action:none";
  var legend = el("div", {"id": "pm-viewer-legend"});
  var info = el("div", {"id": "pm-viewer-info"}, "Click a triangle to see its values.");
  root.appendChild(bar);
  root.appendChild(canvas);
  root.appendChild(legend);
  root.appendChild(info);

  var renderer = new THREE.WebGLRenderer({canvas: canvas, antialias: true, preserveDrawingBuffer: true});
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setSize(canvas.width, canvas.height, false);
  renderer.setClearColor(0xffffff, 1);
  var scene = new THREE.Scene();
  var camera = new THREE.PerspectiveCamera(35, canvas.width / canvas.height, 1e-3, 1e3);
  scene.add(new THREE.AmbientLight(0xffffff, 0.55));
  var light = new THREE.DirectionalLight(0xffffff, 0.6);
  camera.add(light);
  light.position.set(0.3, 0.5, 1);
  scene.add(camera);
  var world = new THREE.Group(); /* rotated by dragging */
  scene.add(world);

  var state = {ci: 0, mi: 0, shown: null, meshes: [], marker: null, dist: 1, pan: [0, 0]};

  function disposeAll() {
    while (world.children.length) {
      var o = world.children.pop();
      if (o.geometry) o.geometry.dispose();
      if (o.material) o.material.dispose();
    }
    state.meshes = [];
    state.marker = null;
  }

  /* One method's mesh: one colour per triangle (three vertices each, not shared), its edges. */
  function build(c, m, offset) {
    var n = m.tri.length / 3, pos = new Float32Array(9 * n), col = new Float32Array(9 * n);
    for (var t = 0; t < n; ++t)
      for (var k = 0; k < 3; ++k) {
        var v = m.tri[3 * t + k];
        pos[9 * t + 3 * k] = m.xyz[3 * v] - c.centre[0] + offset;
        pos[9 * t + 3 * k + 1] = m.xyz[3 * v + 1] - c.centre[1];
        pos[9 * t + 3 * k + 2] = m.xyz[3 * v + 2] - c.centre[2];
      }
    var g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(pos, 3));
    g.setAttribute("color", new THREE.BufferAttribute(col, 3));
    g.computeVertexNormals();
    var mat = c.flat ? new THREE.MeshBasicMaterial({vertexColors: THREE.VertexColors, side: THREE.DoubleSide})
                     : new THREE.MeshLambertMaterial({vertexColors: THREE.VertexColors, side: THREE.DoubleSide});
    mat.polygonOffset = true;
    mat.polygonOffsetFactor = 1;
    mat.polygonOffsetUnits = 1;
    var mesh = new THREE.Mesh(g, mat);
    mesh.userData = {method: m, offset: offset};
    world.add(mesh);
    state.meshes.push(mesh);
    if (n <= 80000) {
      var seen = {}, lines = [];
      for (t = 0; t < n; ++t)
        for (k = 0; k < 3; ++k) {
          var a = m.tri[3 * t + k], b = m.tri[3 * t + (k + 1) % 3], key = a < b ? a + "," + b : b + "," + a;
          if (seen[key]) continue;
          seen[key] = 1;
          lines.push(pos[9 * t + 3 * k], pos[9 * t + 3 * k + 1], pos[9 * t + 3 * k + 2]);
          var k2 = (k + 1) % 3;
          lines.push(pos[9 * t + 3 * k2], pos[9 * t + 3 * k2 + 1], pos[9 * t + 3 * k2 + 2]);
        }
      var lg = new THREE.BufferGeometry();
      lg.setAttribute("position", new THREE.BufferAttribute(new Float32Array(lines), 3));
      world.add(new THREE.LineSegments(lg, new THREE.LineBasicMaterial({color: 0x222222, transparent: true, opacity: 0.35})));
    }
  }

  function recolour() {
    var c = data.cases[state.ci], meas = MEASURES[state.mi];
    state.meshes.forEach(function (mesh) {
      var m = mesh.userData.method, vals = m.values[meas.key], col = mesh.geometry.attributes.color.array;
      for (var t = 0; t < vals.length; ++t) {
        colour(meas.t(vals[t], c.colour_max), col, 9 * t);
        for (var k = 1; k < 3; ++k)
          for (var q = 0; q < 3; ++q) col[9 * t + 3 * k + q] = col[9 * t + q];
      }
      mesh.geometry.attributes.color.needsUpdate = true;
    });
    legend.textContent = "Colour: " + meas.legend(c.colour_max) + ". Left to right: " +
      state.meshes.map(function (x) { return x.userData.method.label; }).join(", ") +
      ". Drag to rotate, wheel to zoom, shift-drag to pan.";
    draw();
  }

  function load() {
    var c = data.cases[state.ci];
    disposeAll();
    if (!c.centre) {
      var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
      c.methods.forEach(function (m) {
        for (var i = 0; i < m.xyz.length; ++i) {
          lo[i % 3] = Math.min(lo[i % 3], m.xyz[i]);
          hi[i % 3] = Math.max(hi[i % 3], m.xyz[i]);
        }
      });
      c.centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
      c.size = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    }
    var shown = c.methods.filter(function (m, i) { return state.shown[i]; });
    var step = 1.15 * Math.max(c.size[0], 1e-12);
    shown.forEach(function (m, i) { build(c, m, (i - (shown.length - 1) / 2) * step); });
    /* Far enough for the row of meshes across and for one mesh's diagonal up and down, whatever
     * way it is turned. */
    var across = step * Math.max(shown.length, 1);
    var diag = Math.sqrt(c.size[0] * c.size[0] + c.size[1] * c.size[1] + c.size[2] * c.size[2]);
    var vhalf = Math.tan(camera.fov * Math.PI / 360), hhalf = vhalf * camera.aspect;
    state.dist = 1.1 * Math.max(0.5 * across / hhalf, 0.5 * diag / vhalf) + 0.5 * diag;
    state.pan = [0, 0];
    camera.near = state.dist / 1000;
    camera.far = state.dist * 10;
    camera.updateProjectionMatrix();
    world.rotation.set(c.flat ? 0 : -1.0, 0, c.flat ? 0 : -0.6);
    recolour();
  }

  function methodBoxes() {
    var c = data.cases[state.ci];
    methodBox.textContent = "";
    state.shown = c.methods.map(function () { return true; });
    c.methods.forEach(function (m, i) {
      var label = el("label", {});
      var box = el("input", {type: "checkbox", "data-method": m.label});
      box.checked = true;
      box.addEventListener("change", function () { state.shown[i] = box.checked; load(); });
      label.appendChild(box);
      label.appendChild(document.createTextNode(" " + m.label + " "));
      methodBox.appendChild(label);
    });
  }

  function draw() {
    camera.position.set(state.pan[0], state.pan[1], state.dist);
    camera.lookAt(state.pan[0], state.pan[1], 0);
    renderer.render(scene, camera);
  }

  /* ---- picking ---- */
  var raycaster = new THREE.Raycaster();
  function pick(px, py) {
    var rect = canvas.getBoundingClientRect();
    var ndc = new THREE.Vector2(2 * (px - rect.left) / rect.width - 1, 1 - 2 * (py - rect.top) / rect.height);
    raycaster.setFromCamera(ndc, camera);
    var hit = raycaster.intersectObjects(state.meshes, false)[0];
    if (!hit) {
      info.textContent = "No triangle there.";
      return null;
    }
    var m = hit.object.userData.method, t = hit.faceIndex, c = data.cases[state.ci];
    var nodes = [m.tri[3 * t], m.tri[3 * t + 1], m.tri[3 * t + 2]];
    var text = m.label + ", triangle " + t + " (nodes " + nodes.join(", ") + "): R/l_min " +
      m.values.aspect_ratio[t].toPrecision(4) + ", radius ratio " + m.values.radius_ratio[t].toPrecision(4) +
      ", smallest angle " + m.values.min_angle_deg[t].toPrecision(4) + " degrees.";
    info.textContent = text;
    if (state.marker) {
      world.remove(state.marker);
      state.marker.geometry.dispose();
    }
    var pos = hit.object.geometry.attributes.position.array, pts = [];
    for (var k = 0; k < 4; ++k) pts.push(pos[9 * t + 3 * (k % 3)], pos[9 * t + 3 * (k % 3) + 1], pos[9 * t + 3 * (k % 3) + 2]);
    var g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(new Float32Array(pts), 3));
    state.marker = new THREE.Line(g, new THREE.LineBasicMaterial({color: 0x000000, depthTest: false}));
    world.add(state.marker);
    draw();
    return {method: m.label, triangle: t, text: text, case: c.name};
  }

  /* ---- mouse ---- */
  var drag = null;
  canvas.addEventListener("pointerdown", function (e) {
    drag = {x: e.clientX, y: e.clientY, x0: e.clientX, y0: e.clientY, pan: e.shiftKey};
    canvas.setPointerCapture && canvas.setPointerCapture(e.pointerId);
  });
  canvas.addEventListener("pointermove", function (e) {
    if (!drag) return;
    var dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX;
    drag.y = e.clientY;
    if (drag.pan) {
      var s = state.dist / canvas.clientHeight;
      state.pan[0] -= dx * s;
      state.pan[1] += dy * s;
    } else {
      world.rotation.x += dy * 0.01;
      world.rotation.z += dx * 0.01;
    }
    draw();
  });
  canvas.addEventListener("pointerup", function (e) {
    if (drag && Math.abs(e.clientX - drag.x0) + Math.abs(e.clientY - drag.y0) < 4) pick(e.clientX, e.clientY);
    drag = null;
  });
  canvas.addEventListener("wheel", function (e) {
    e.preventDefault();
    state.dist *= Math.exp(0.001 * e.deltaY);
    draw();
  }, {passive: false});
  caseSel.addEventListener("change", function () {
    state.ci = +caseSel.value;
    methodBoxes();
    load();
  });
  measureSel.addEventListener("change", function () {
    state.mi = +measureSel.value;
    recolour();
  });

  methodBoxes();
  load();
  /* For scripts and tests: pick at a page position, or at the centre of the canvas. */
  window.pmViewer = {
    state: state,
    pick: pick,
    /* The page position of triangle t of the k-th mesh shown (its centroid), for a click. */
    screenOf: function (k, t) {
      var mesh = state.meshes[k], pos = mesh.geometry.attributes.position.array, p = new THREE.Vector3();
      for (var q = 0; q < 3; ++q)
        p.add(new THREE.Vector3(pos[9 * t + 3 * q], pos[9 * t + 3 * q + 1], pos[9 * t + 3 * q + 2]));
      p.multiplyScalar(1 / 3);
      world.updateMatrixWorld();
      p.applyMatrix4(world.matrixWorld).project(camera);
      var r = canvas.getBoundingClientRect();
      return [r.left + (p.x + 1) / 2 * r.width, r.top + (1 - p.y) / 2 * r.height];
    },
    select: function (ci, mi) {
      caseSel.value = ci;
      caseSel.dispatchEvent(new Event("change"));
      if (mi !== undefined) {
        measureSel.value = mi;
        measureSel.dispatchEvent(new Event("change"));
      }
    }
  };
})();
