//! The report's interactive 3D view in headless Chromium with software WebGL (SwiftShader): the
//! page loads with a silent console; each class shown alone puts pixels of its colour in the
//! canvas; the picture changes between the slider's ends and after a drag; the volumes follow
//! the slider; the plane view (the report given the model's input) shows another picture at the
//! slider's other end; the page does not scroll sideways at 1200 px; without the input the
//! report still works and says how to get the plane view. The checks run in a script added
//! to a copy of the report (the report itself carries none). Skips with a notice where Chromium
//! is not installed; CI installs it and sets DYNASLICE_REQUIRE_PYTHON, where that fails.

mod common;

use common::succeeded;
use dynaslice_test_support::browser::{browse_webgl, chromium};
use dynaslice_test_support::spheres::{self, Sphere};
use std::path::Path;
use std::process::Command;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Run once the page has loaded; writes its findings into `<body data-view>`.
const CHECKS: &str = r#"<script>
window.addEventListener('load', function () {
  var out = [];
  try {
    var root = document.querySelector('.dsv');
    var canvas = root.querySelector('[data-dsv="canvas"]');
    var gl = canvas.getContext('webgl');
    var scene = JSON.parse(root.querySelector('[data-dsv="scene"]').textContent);
    var pixels = function () {
      var p = new Uint8Array(canvas.width * canvas.height * 4);
      gl.readPixels(0, 0, canvas.width, canvas.height, gl.RGBA, gl.UNSIGNED_BYTE, p);
      return p;
    };
    // Pixels that are a shade (lit 0.3 to 1) of colour c.
    var shades = function (p, c) {
      var n = 0, cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
      for (var i = 0; i < p.length; i += 4) {
        var f = (p[i] * c[0] + p[i + 1] * c[1] + p[i + 2] * c[2]) / cc;
        if (f < 0.3 || f > 1.02) continue;
        if (Math.abs(p[i] - f * c[0]) < 6 && Math.abs(p[i + 1] - f * c[1]) < 6 &&
            Math.abs(p[i + 2] - f * c[2]) < 6) n++;
      }
      return n;
    };
    var differ = function (a, b) {
      var n = 0;
      for (var i = 0; i < a.length; i += 4) {
        if (a[i] !== b[i] || a[i + 1] !== b[i + 1] || a[i + 2] !== b[i + 2]) n++;
      }
      return n;
    };
    var boxes = root.querySelectorAll('[data-dsv="class"]');
    var only = function (k) {
      for (var j = 0; j < boxes.length; j++) {
        boxes[j].checked = k < 0 || j === k;
        boxes[j].dispatchEvent(new Event('change'));
      }
    };
    out.push('size=' + canvas.width + 'x' + canvas.height);
    for (var k = 0; k < scene.classes.length; k++) {
      only(k);
      out.push('class' + k + '=' + shades(pixels(), scene.classes[k].color));
    }
    only(-1);
    var slider = root.querySelector('[data-dsv="time"]');
    var volume = root.querySelector('[data-dsv="volume"]');
    slider.value = '0';
    slider.dispatchEvent(new Event('input'));
    var first = pixels(), v0 = volume.textContent;
    slider.value = String(scene.frames.length - 1);
    slider.dispatchEvent(new Event('input'));
    var last = pixels(), v1 = volume.textContent;
    out.push('slider=' + differ(first, last));
    // The plane view: the picture shown (one not hidden) at each end of the slider, its pixels
    // read through a 2D canvas (data: URIs are same-origin).
    var planePixels = function () {
      var shown = root.querySelectorAll('[data-dsv="plane"] img:not([hidden])');
      if (shown.length !== 1) return null;
      var img = shown[0], c = document.createElement('canvas');
      c.width = img.naturalWidth;
      c.height = img.naturalHeight;
      var g = c.getContext('2d');
      g.drawImage(img, 0, 0);
      return g.getImageData(0, 0, c.width, c.height).data;
    };
    var planeLast = planePixels();
    slider.value = '0';
    slider.dispatchEvent(new Event('input'));
    var planeFirst = planePixels();
    out.push('plane=' + (planeFirst && planeLast && planeFirst.length === planeLast.length ?
      differ(planeFirst, planeLast) : 'none'));
    slider.value = String(scene.frames.length - 1);
    slider.dispatchEvent(new Event('input'));
    out.push('volumes=' + v0 + '/' + v1);
    var r = canvas.getBoundingClientRect();
    var pointer = function (type, target, x, y) {
      target.dispatchEvent(new PointerEvent(type, { clientX: r.left + x, clientY: r.top + y,
        button: 0, buttons: 1, bubbles: true, pointerId: 1, isPrimary: true }));
    };
    pointer('pointerdown', canvas, 100, 100);
    pointer('pointermove', window, 180, 130);
    pointer('pointerup', window, 180, 130);
    out.push('drag=' + differ(last, pixels()));
    var page = document.documentElement;
    out.push('sideways=' + (page.scrollWidth - page.clientWidth));
  } catch (e) {
    out.push('error=' + String(e).replace(/ /g, '_'));
  }
  document.body.setAttribute('data-view', out.join(' '));
});
</script>
"#;

/// A native JSON input of the two balls' model below: frames at times 0 and 2, each one axial
/// plane through the balls' centre (world z = 2) with a square of half-side `r` mm around the
/// ball (10, −5): the ball's world radius is 10 mm at t = 0 and 13.4 mm at t = 2.
fn write_input(path: &Path) {
    let frame = |t: f64, r: f64| {
        let (x0, x1, y0, y1) = (10.0 - r, 10.0 + r, -5.0 - r, -5.0 + r);
        format!(
            r#"{{"time": {t}, "planes": [{{"origin": [0.0, 0.0, 2.0], "u": [1.0, 0.0, 0.0],
            "v": [0.0, 1.0, 0.0], "roi": {{"min": [-10.0, -25.0], "max": [30.0, 15.0]}},
            "annotations": [{{"class": 0, "polygons": [[[{x0}, {y0}], [{x1}, {y0}],
            [{x1}, {y1}], [{x0}, {y1}]]]}}]}}]}}"#
        )
    };
    let doc = format!(
        r#"{{"format": "dynaslice-sections", "version": 1,
          "classes": [{{"name": "ball", "label": 1}}],
          "frames": [{}, {}]}}"#,
        frame(0.0, 9.0),
        frame(2.0, 12.0)
    );
    std::fs::write(path, doc).unwrap();
}

/// The value of `key=` in the findings.
fn finding<'a>(findings: &'a str, key: &str) -> &'a str {
    findings
        .split_whitespace()
        .find_map(|f| f.strip_prefix(&format!("{key}=")))
        .unwrap_or_else(|| panic!("no {key} in {findings}"))
}

#[test]
fn interactive_view_turns_plays_and_shows_every_class() {
    let dir = tempfile::tempdir().unwrap();
    // Class 1 grows over time (normalised radius² = 0.25 + 0.1·t); class 2 stays.
    let model = dir.path().join("m.dsm");
    std::fs::write(
        &model,
        spheres::model(
            &[
                Sphere::new([0.0; 3], 0.5, 0.1),
                Sphere::new([0.4, 0.0, 0.0], 0.3, 0.0),
            ],
            &[("ball", 1), ("small ball", 7)],
        ),
    )
    .unwrap();
    let report = |html: &Path, input: &[&Path]| {
        succeeded(
            &Command::new(env!("CARGO_BIN_EXE_dynaslice"))
                .args(["report", s(&model)])
                .args(input.iter().map(|p| s(p)))
                .args(["-o", s(html)])
                .args(["--times", "0:2:5", "--resolution", "48"])
                .output()
                .unwrap(),
        );
        std::fs::read_to_string(html).unwrap()
    };
    // Without the input: no plane view, and the page says how to get one.
    let bare = report(&dir.path().join("bare.html"), &[]);
    assert_eq!(bare.matches("<canvas").count(), 1);
    assert!(bare.contains("No plane view"), "no note on the plane view");
    assert!(!bare.contains("<figure class=\"dsv-plane\""));
    let input = dir.path().join("balls.json");
    write_input(&input);
    let html = dir.path().join("report.html");
    let text = report(&html, &[&input]);
    assert_eq!(text.matches("<canvas").count(), 1);
    // One plane picture per time, the plane named by the input.
    assert_eq!(text.matches("<figure class=\"dsv-plane\"").count(), 1);
    assert!(!text.contains("No plane view"));
    let pictures = text.matches(" src=\"data:image/png;base64,").count()
        - bare.matches(" src=\"data:image/png;base64,").count();
    assert_eq!(pictures, 5);
    assert!(text.contains("Plane 0 of the first frame of "));
    assert!(text.contains("balls.json (its plane with the most contour)"));
    println!(
        "plane view: {} bytes for {pictures} pictures, {} per picture",
        text.len() - bare.len(),
        (text.len() - bare.len()) / pictures
    );
    // The still picture stays, for printing and browsers without WebGL.
    assert!(text.contains("seen from the front"));
    let Some(browser) = chromium() else { return };

    // The report as it is: it loads with a silent console.
    let plain = browse_webgl(browser, &html, &["--dump-dom"]);
    assert!(
        plain.status.success(),
        "{}",
        String::from_utf8_lossy(&plain.stderr)
    );
    let log = String::from_utf8_lossy(&plain.stderr);
    let console: Vec<&str> = log.lines().filter(|l| l.contains(":CONSOLE")).collect();
    assert!(console.is_empty(), "console messages: {console:#?}");
    assert!(String::from_utf8_lossy(&plain.stdout).contains("data-images=\"ok"));

    // A copy with the checks.
    let checked = dir.path().join("checked.html");
    std::fs::write(
        &checked,
        text.replace("</body>", &format!("{CHECKS}</body>")),
    )
    .unwrap();
    let out = browse_webgl(browser, &checked, &["--dump-dom"]);
    let dom = String::from_utf8_lossy(&out.stdout);
    let findings = dom
        .split("data-view=\"")
        .nth(1)
        .and_then(|rest| rest.split('"').next())
        .unwrap_or_else(|| panic!("no findings: {}", String::from_utf8_lossy(&out.stderr)));
    println!("findings: {findings}");
    assert!(!findings.contains("error="), "{findings}");
    for k in 0..2 {
        let n: usize = finding(findings, &format!("class{k}")).parse().unwrap();
        assert!(n > 500, "class {k}: {n} pixels of its colour: {findings}");
    }
    let changed = |key: &str| finding(findings, key).parse::<usize>().unwrap();
    assert!(changed("slider") > 500, "{findings}");
    assert!(changed("drag") > 500, "{findings}");
    // The ball grows from 10 to 13.4 mm on a 40 mm plane of at most 480 px: thousands of pixels.
    assert!(changed("plane") > 1000, "{findings}");
    let (v0, v1) = finding(findings, "volumes").split_once('/').unwrap();
    let (v0, v1): (f64, f64) = (v0.parse().unwrap(), v1.parse().unwrap());
    assert!(v1 > v0, "the ball grows: {v0} then {v1}");
    assert_eq!(finding(findings, "sideways"), "0", "{findings}");
}
