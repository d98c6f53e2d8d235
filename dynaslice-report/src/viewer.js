// DynaSlice report: the interactive 3D view (viewer.rs writes the markup, the scene as JSON and
// the geometry as base64 beside this script). WebGL 1, no library, nothing fetched. Written for
// DynaSlice; same licence as the project (MIT OR Apache-2.0).
(function () {
  'use strict';
  var root = document.currentScript.parentNode;
  function part(name) { return root.querySelector('[data-dsv="' + name + '"]'); }
  var scene = JSON.parse(part('scene').textContent);
  var canvas = part('canvas');
  var gl = null;
  try {
    // The drawing buffer is kept so that what is shown can be read back (tests, screenshots).
    gl = canvas.getContext('webgl', { preserveDrawingBuffer: true, antialias: true });
  } catch (e) {
    gl = null;
  }
  if (!gl) {
    part('main').hidden = true;
    part('nogl').hidden = false;
    return;
  }

  // Geometry: little-endian u16 words; positions quantised over the scene's box.
  var text = atob(part('geometry').textContent.trim());
  var words = new Uint16Array(text.length >> 1);
  for (var i = 0; i < words.length; i++) {
    words[i] = text.charCodeAt(2 * i) | (text.charCodeAt(2 * i + 1) << 8);
  }
  text = null;

  function shader(type, source) {
    var s = gl.createShader(type);
    gl.shaderSource(s, source);
    gl.compileShader(s);
    return s;
  }
  var program = gl.createProgram();
  gl.attachShader(program, shader(gl.VERTEX_SHADER,
    'attribute vec3 q;attribute vec3 n;uniform mat4 mvp;uniform mat4 view;' +
    'uniform vec3 lo;uniform vec3 step;varying vec3 vn;' +
    'void main(){gl_Position=mvp*vec4(lo+q*step,1.0);vn=(view*vec4(n,0.0)).xyz;}'));
  gl.attachShader(program, shader(gl.FRAGMENT_SHADER,
    'precision mediump float;varying vec3 vn;uniform vec3 color;' +
    'void main(){float l=length(vn);float d=l>1e-6?abs(vn.z)/l:1.0;' +
    'gl_FragColor=vec4(color*(0.35+0.65*d),1.0);}'));
  gl.linkProgram(program);
  gl.useProgram(program);
  var loc = {
    q: gl.getAttribLocation(program, 'q'),
    n: gl.getAttribLocation(program, 'n'),
    mvp: gl.getUniformLocation(program, 'mvp'),
    view: gl.getUniformLocation(program, 'view'),
    lo: gl.getUniformLocation(program, 'lo'),
    step: gl.getUniformLocation(program, 'step'),
    color: gl.getUniformLocation(program, 'color')
  };
  gl.uniform3fv(loc.lo, scene.lo);
  gl.uniform3fv(loc.step, scene.step);
  gl.enableVertexAttribArray(loc.q);
  gl.enableVertexAttribArray(loc.n);
  gl.enable(gl.DEPTH_TEST);

  // Buffers are made the first time a mesh is shown; normals are the area-weighted face
  // normals summed at each vertex.
  var buffers = [];
  function mesh(f, k) {
    var key = f * scene.classes.length + k;
    if (buffers[key]) return buffers[key];
    var m = scene.frames[f].meshes[k];
    var vo = m[0], nv = m[1], io = m[2], ni = m[3];
    var q = words.subarray(vo, vo + 3 * nv), idx = words.subarray(io, io + ni);
    var normals = new Float32Array(3 * nv);
    for (var t = 0; t < ni; t += 3) {
      var a = 3 * idx[t], b = 3 * idx[t + 1], c = 3 * idx[t + 2];
      var u = [], v = [];
      for (var x = 0; x < 3; x++) {
        u[x] = (q[b + x] - q[a + x]) * scene.step[x];
        v[x] = (q[c + x] - q[a + x]) * scene.step[x];
      }
      var nx = u[1] * v[2] - u[2] * v[1], ny = u[2] * v[0] - u[0] * v[2], nz = u[0] * v[1] - u[1] * v[0];
      for (var j = 0; j < 3; j++) {
        var p = 3 * idx[t + j];
        normals[p] += nx; normals[p + 1] += ny; normals[p + 2] += nz;
      }
    }
    var vb = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, vb);
    gl.bufferData(gl.ARRAY_BUFFER, q, gl.STATIC_DRAW);
    var nb = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, nb);
    gl.bufferData(gl.ARRAY_BUFFER, normals, gl.STATIC_DRAW);
    var ib = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ib);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, idx, gl.STATIC_DRAW);
    buffers[key] = { vb: vb, nb: nb, ib: ib, count: ni };
    return buffers[key];
  }

  // The camera orbits a target: yaw about the superior axis from the front (anterior, +y),
  // pitch above it; it starts a little to the patient's right (+x) and above, as the pictures.
  var extent = [0, 1, 2].map(function (x) { return 65535 * scene.step[x]; });
  var centre = [0, 1, 2].map(function (x) { return scene.lo[x] + extent[x] / 2; });
  var radius = Math.max(1e-9, Math.sqrt(extent[0] * extent[0] + extent[1] * extent[1] + extent[2] * extent[2]) / 2);
  var fov = 0.6;
  var cam;
  function reset() {
    cam = { yaw: 0.35, pitch: 0.3, dist: 1.05 * radius / Math.sin(fov / 2), target: centre.slice() };
  }
  reset();

  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function unit(a) { var l = Math.sqrt(dot(a, a)) || 1; return [a[0] / l, a[1] / l, a[2] / l]; }
  function basis() {
    var cp = Math.cos(cam.pitch);
    var d = [Math.sin(cam.yaw) * cp, Math.cos(cam.yaw) * cp, Math.sin(cam.pitch)];
    var eye = [0, 1, 2].map(function (x) { return cam.target[x] + cam.dist * d[x]; });
    var f = unit(sub(cam.target, eye));
    var s = unit(cross(f, [0, 0, 1]));
    return { eye: eye, f: f, s: s, u: cross(s, f) };
  }
  function multiply(a, b) {
    var out = new Float32Array(16);
    for (var c = 0; c < 4; c++) {
      for (var r = 0; r < 4; r++) {
        var v = 0;
        for (var k = 0; k < 4; k++) v += a[k * 4 + r] * b[c * 4 + k];
        out[c * 4 + r] = v;
      }
    }
    return out;
  }

  var frame = 0;
  var shown = scene.classes.map(function () { return true; });
  function draw() {
    var w = canvas.width, h = canvas.height;
    gl.viewport(0, 0, w, h);
    gl.clearColor(0.98, 0.98, 0.98, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    var b = basis(), e = b.eye, s = b.s, u = b.u, f = b.f;
    var view = new Float32Array([s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
      -dot(s, e), -dot(u, e), dot(f, e), 1]);
    var near = Math.max(cam.dist - 2 * radius, cam.dist / 100), far = cam.dist + 2 * radius;
    var t = 1 / Math.tan(fov / 2), aspect = w / Math.max(1, h);
    var projection = new Float32Array([t / aspect, 0, 0, 0, 0, t, 0, 0, 0, 0, (far + near) / (near - far), -1,
      0, 0, 2 * far * near / (near - far), 0]);
    gl.uniformMatrix4fv(loc.mvp, false, multiply(projection, view));
    gl.uniformMatrix4fv(loc.view, false, view);
    for (var k = 0; k < scene.classes.length; k++) {
      if (!shown[k] || scene.frames[frame].meshes[k][3] === 0) continue;
      var m = mesh(frame, k);
      var c = scene.classes[k].color;
      gl.uniform3f(loc.color, c[0] / 255, c[1] / 255, c[2] / 255);
      gl.bindBuffer(gl.ARRAY_BUFFER, m.vb);
      gl.vertexAttribPointer(loc.q, 3, gl.UNSIGNED_SHORT, false, 0, 0);
      gl.bindBuffer(gl.ARRAY_BUFFER, m.nb);
      gl.vertexAttribPointer(loc.n, 3, gl.FLOAT, false, 0, 0);
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, m.ib);
      gl.drawElements(gl.TRIANGLES, m.count, gl.UNSIGNED_SHORT, 0);
    }
  }
  function resize() {
    var ratio = window.devicePixelRatio || 1;
    canvas.width = Math.max(1, Math.round(canvas.clientWidth * ratio));
    canvas.height = Math.max(1, Math.round(canvas.clientHeight * ratio));
    draw();
  }

  // Time: the slider, the play button, and the volumes of the time shown.
  var slider = part('time'), label = part('time-label'), play = part('play');
  var volumes = root.querySelectorAll('[data-dsv="volume"]');
  // The plane view, where the report has one: one picture per time, the time's shown.
  var planes = root.querySelectorAll('[data-dsv="plane"] img');
  function setFrame(f) {
    frame = f;
    slider.value = String(f);
    var fr = scene.frames[f];
    label.textContent = scene.timeLabel + ' ' + fr.time;
    for (var k = 0; k < volumes.length; k++) {
      var v = fr.volumes[k];
      volumes[k].textContent = v === null ? '\u2013' : String(v);
    }
    for (var p = 0; p < planes.length; p++) planes[p].hidden = p !== f;
    draw();
  }
  slider.addEventListener('input', function () { setFrame(Number(slider.value)); });
  var timer = null;
  play.addEventListener('click', function () {
    if (timer !== null) {
      clearInterval(timer);
      timer = null;
      play.textContent = 'Play';
      return;
    }
    play.textContent = 'Pause';
    timer = setInterval(function () { setFrame((frame + 1) % scene.frames.length); }, 250);
  });
  var toggles = root.querySelectorAll('[data-dsv="class"]');
  Array.prototype.forEach.call(toggles, function (box, k) {
    box.addEventListener('change', function () { shown[k] = box.checked; draw(); });
  });

  // Mouse (and touch, through pointer events): drag turns, shift- or right-drag pans, the wheel
  // zooms, a double click goes back to the first view.
  var drag = null;
  canvas.addEventListener('pointerdown', function (e) {
    drag = { x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey };
    e.preventDefault();
  });
  window.addEventListener('pointermove', function (e) {
    if (!drag) return;
    var dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX;
    drag.y = e.clientY;
    if (drag.pan) {
      var b = basis(), perPixel = 2 * cam.dist * Math.tan(fov / 2) / Math.max(1, canvas.clientHeight);
      for (var x = 0; x < 3; x++) cam.target[x] += (-dx * b.s[x] + dy * b.u[x]) * perPixel;
    } else {
      cam.yaw -= dx * 0.01;
      cam.pitch = Math.max(-1.55, Math.min(1.55, cam.pitch + dy * 0.01));
    }
    draw();
  });
  window.addEventListener('pointerup', function () { drag = null; });
  canvas.addEventListener('wheel', function (e) {
    e.preventDefault();
    cam.dist = Math.max(radius * 0.05, Math.min(radius * 20, cam.dist * Math.exp(e.deltaY * 0.001)));
    draw();
  }, { passive: false });
  canvas.addEventListener('contextmenu', function (e) { e.preventDefault(); });
  canvas.addEventListener('dblclick', function () { reset(); draw(); });
  window.addEventListener('resize', resize);
  resize();
  setFrame(0);
}());
